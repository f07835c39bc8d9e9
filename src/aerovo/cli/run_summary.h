// The end of `aerovo run` on the terminal: pipeline's FormatRunSummary (a one-line answer a
// pilot understands, then the details) and the files written, every line within 80 columns. One function taking the stream, so the caller chooses stdout or
// stderr (stderr when stdout carries the pose stream).
#pragma once

#include <ostream>
#include <string>

#include "aerovo/pipeline/runner.h"

namespace aerovo::cli {

/// `folder`'s file names (and sub-folders, with a '/'), sorted, as lines of at most `width`
/// columns after an indent of two spaces; the folder's lock and space reserve (outputs/run_folder.h
/// RunFolderFiles) are left out.
std::string WrappedFileList(const std::string& folder, int width = 80);

/// Prints FormatRunSummary (pipeline/runner.h: the headline, then the details) and the files
/// written, to `out`.
void PrintRunSummary(std::ostream& out, const RunSummary& summary);

}  // namespace aerovo::cli
