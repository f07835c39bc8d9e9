#include "aerovo/cli/run_summary.h"

#include <algorithm>
#include <filesystem>
#include <system_error>
#include <vector>

#include "aerovo/outputs/run_folder.h"

namespace aerovo::cli {

std::string WrappedFileList(const std::string& folder, int width) {
  namespace fs = std::filesystem;
  std::vector<std::string> names;
  std::error_code ec;
  for (const fs::directory_entry& e : fs::directory_iterator(folder, ec)) {
    const std::string name = e.path().filename().string();
    // The folder's lock and space reserve (outputs/run_folder.h) are the run's bookkeeping, not
    // its outputs: the lock file stays after the run by design, the reserve is removed.
    if (name == RunFolderFiles::kLock || name == RunFolderFiles::kReserve) continue;
    names.push_back(name + (e.is_directory(ec) ? "/" : ""));
  }
  std::sort(names.begin(), names.end());
  std::string out, line;
  for (const std::string& n : names) {
    if (!line.empty() && static_cast<int>(2 + line.size() + 1 + n.size()) > width) {
      out += "  " + line + "\n";
      line.clear();
    }
    line += (line.empty() ? "" : " ") + n;
  }
  if (!line.empty()) out += "  " + line + "\n";
  return out;
}

void PrintRunSummary(std::ostream& out, const RunSummary& s) {
  out << FormatRunSummary(s);
  out << "\nOutputs in " << s.out_dir.string() << "/:\n" << WrappedFileList(s.out_dir.string());
}

}  // namespace aerovo::cli
