// Error types. Every error aerovo raises says what was wrong and, where there is one, which
// file, line or frame it concerns.
//
// One hierarchy under aerovo::Error for what the outside world or a stop request causes:
//   Error
//   ├── InputError      bad outside data: an unreadable or malformed file, stream or frame
//   ├── OutputError     a write to an output file or folder failed (disk full, size limit,
//   │                   I/O error, a folder that cannot be created)
//   ├── Cancelled       a computation stopped by a stop request (core/cancel.h)
//   └── InternalError   a broken invariant of aerovo itself (a bug, never the user's data)
// The four are siblings: a handler names each type it handles (catch order carries no meaning),
// and the CLI maps each to its exit code in one place (ExitCodeForError, cli/conventions.h).
// InvalidArgument (bad options: the caller's bug or a bad configuration) stays a
// std::invalid_argument so that it reads as a usage error wherever options are checked.
#pragma once

#include <stdexcept>
#include <string>

namespace aerovo {

/// Invalid argument or options (caller's bug or bad configuration).
class InvalidArgument : public std::invalid_argument {
 public:
  using std::invalid_argument::invalid_argument;
};

/// The base of aerovo's run-time errors (see the hierarchy above).
class Error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Bad outside data: an unreadable or malformed file, stream or frame. The message names the
/// source (file path, and line or frame where known) and the problem.
class InputError : public Error {
 public:
  using Error::Error;
};

/// A write to an output file or folder failed (disk full, size limit, I/O error). The message
/// names the file and the errno text.
class OutputError : public Error {
 public:
  using Error::Error;
};

/// Thrown by a computation stopped by CancelRequested() (core/cancel.h); the frame being
/// processed is abandoned (not counted as processed).
class Cancelled : public Error {
 public:
  explicit Cancelled(const std::string& where) : Error("cancelled in " + where) {}
};

/// A broken invariant of aerovo itself: a bug, never the user's data.
class InternalError : public Error {
 public:
  using Error::Error;
};

}  // namespace aerovo
