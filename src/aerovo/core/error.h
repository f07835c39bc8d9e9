// Error types. Every error aerovo raises says what was wrong and, where there is one, which
// file, line or frame it concerns.
#pragma once

#include <stdexcept>
#include <string>

namespace aerovo {

/// Invalid argument or options (caller's bug or bad configuration).
class InvalidArgument : public std::invalid_argument {
 public:
  using std::invalid_argument::invalid_argument;
};

/// Bad outside data: an unreadable or malformed file, stream or frame. The message names the
/// source (file path, and line or frame where known) and the problem.
class InputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

}  // namespace aerovo
