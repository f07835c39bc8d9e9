#include "aerovo/cli/conventions.h"

#include <algorithm>
#include <cctype>
#include <functional>
#include <iterator>
#include <set>

namespace aerovo::cli {

namespace {

template <class T>
bool Is(const std::exception& e) {
  return dynamic_cast<const T*>(&e) != nullptr;
}

}  // namespace

std::string NameFlags(const std::string& message,
                      const std::vector<std::pair<const char*, const char*>>& fields) {
  std::string flags;
  for (const auto& [field, flag] : fields) {
    if (message.find(field) == std::string::npos) continue;
    flags += (flags.empty() ? "" : ", ") + std::string(flag);
  }
  return flags.empty() ? message : flags + ": " + message;
}

int ExitCodeForError(const std::exception& error) {
  // The types are disjoint (core/error.h): the order of the tests carries no meaning.
  if (Is<UsageError>(error)) return kExitUsage;
  if (Is<InputError>(error)) return kExitFailure;
  if (Is<OutputError>(error)) return kExitFailure;
  if (Is<Cancelled>(error)) return kExitFailure;
  if (Is<InternalError>(error)) return kExitFailure;
  return kExitFailure;  // InvalidArgument, another std::exception
}

std::string ExitCodesHelp() {
  return "Exit codes:\n"
         "  0    success (also --help, --version, aerovo alone)\n"
         "  1    the command failed: bad input data, a file it could not read or write\n"
         "  2    usage error: unknown command or option, bad or missing value, a value out of\n"
         "       its range\n"
         "  130  stopped by SIGINT (Ctrl-C), 143 by SIGTERM, 129 by SIGHUP (the terminal closed),\n"
         "       141 by SIGPIPE (the reader of the output went away): 128 + the signal; run,\n"
         "       experiment and demo stop after the current frame, every output valid up to it\n";
}

int EditDistance(const std::string& a, const std::string& b) {
  std::vector<int> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) row[j] = static_cast<int>(j);
  for (std::size_t i = 1; i <= a.size(); ++i) {
    int diag = row[0];  // row[i-1][j-1]
    row[0] = static_cast<int>(i);
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const int up = row[j];  // row[i-1][j]
      row[j] = std::min({up + 1, row[j - 1] + 1, diag + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diag = up;
    }
  }
  return row[b.size()];
}

std::string NearestName(const std::string& word, const std::vector<std::string>& candidates) {
  if (word.empty()) return "";
  // Dashes are not part of the word's length budget ("--surf-treshold" is 13 letters).
  const std::size_t letters = word.size() - std::min(word.find_first_not_of('-'), word.size());
  const int budget = letters <= 8 ? 2 : 3;
  std::string best;
  int best_d = budget + 1;
  for (const std::string& c : candidates) {
    const int d = EditDistance(word, c);
    if (d < best_d) {
      best_d = d;
      best = c;
    }
  }
  if (!best.empty()) return best;
  // A unique-enough prefix: the shortest candidate it begins (at least 3 letters typed).
  if (letters < 3) return "";
  for (const std::string& c : candidates) {
    if (c.size() > word.size() && c.compare(0, word.size(), word) == 0 &&
        (best.empty() || c.size() < best.size())) {
      best = c;
    }
  }
  return best;
}

std::vector<std::string> SubcommandNames(const CLI::App& app) {
  std::vector<std::string> names;
  for (const CLI::App* sub : app.get_subcommands([](const CLI::App*) { return true; })) {
    if (!sub->get_group().empty()) names.push_back(sub->get_name());
  }
  return names;
}

std::vector<std::string> OptionNames(const CLI::App& app) {
  std::vector<std::string> names;
  for (const CLI::Option* o : app.get_options()) {
    for (const std::string& l : o->get_lnames()) names.push_back("--" + l);
    for (const std::string& s : o->get_snames()) names.push_back("-" + s);
  }
  return names;
}

namespace {

std::string Join(const std::vector<std::string>& words) {
  std::string s;
  for (const std::string& w : words) s += (s.empty() ? "" : " ") + w;
  return s;
}

// One `case` arm per command path ("aerovo", "aerovo experiment", "aerovo experiment ransac"):
// the words offered there (subcommands first, then options).
void CompletionCases(const CLI::App& app, const std::string& path, std::string* out) {
  const std::vector<std::string> subs = SubcommandNames(app);
  std::vector<std::string> opts;
  for (const CLI::Option* o : app.get_options()) {
    if (o->get_group().empty()) continue;  // hidden: old spellings are accepted, not offered
    for (const std::string& l : o->get_lnames()) opts.push_back("--" + l);
    for (const std::string& s : o->get_snames()) opts.push_back("-" + s);
  }
  *out += "    '" + path + "') subs='" + Join(subs) + "'; opts='" + Join(opts) + "' ;;\n";
  for (const CLI::App* sub : app.get_subcommands([](const CLI::App*) { return true; })) {
    if (sub->get_group().empty()) continue;
    CompletionCases(*sub, path + " " + sub->get_name(), out);
  }
}

}  // namespace

std::string BashCompletion(const CLI::App& app, const std::string& name) {
  std::string cases;
  CompletionCases(app, name, &cases);
  const std::string fn = "_" + name + "_complete";
  return "# bash completion for " + name + " (generated by `" + name +
         " completion bash` from its command and flag tables)\n" + fn +
         "() {\n"
         "  local cur=${COMP_WORDS[COMP_CWORD]} path=" + name + " subs opts w i\n"
         "  # The command path: the subcommand words typed so far.\n"
         "  for ((i = 1; i < COMP_CWORD; i++)); do\n"
         "    w=${COMP_WORDS[i]}\n"
         "    [[ $w == -* ]] && continue\n"
         "    " + fn + "_words \"$path\"\n"
         "    [[ \" $subs \" == *\" $w \"* ]] && path=\"$path $w\"\n"
         "  done\n"
         "  " + fn + "_words \"$path\"\n"
         "  if [[ $cur == -* ]]; then\n"
         "    COMPREPLY=($(compgen -W \"$opts\" -- \"$cur\"))\n"
         "  elif [[ -n $subs ]]; then\n"
         "    COMPREPLY=($(compgen -W \"$subs\" -- \"$cur\"))\n"
         "  else\n"
         "    COMPREPLY=($(compgen -f -- \"$cur\"))\n"
         "  fi\n"
         "}\n" + fn +
         "_words() {\n"
         "  case $1 in\n" + cases +
         "    *) subs=''; opts='' ;;\n"
         "  esac\n"
         "}\n"
         "complete -o filenames -F " + fn + " " + name + "\n";
}

bool IsBooleanWord(const std::string& word) {
  std::string w;
  for (const char c : word) w += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  static const char* const kWords[] = {"true", "false", "1", "0", "on", "off", "yes", "no"};
  return std::any_of(std::begin(kWords), std::end(kWords),
                     [&w](const char* k) { return w == k; });
}

namespace {

void CollectFlagNames(const CLI::App& app, std::set<std::string>& out) {
  for (const CLI::Option* opt : app.get_options()) {
    if (opt->get_expected_max() != 0) continue;  // takes a value: not a flag
    for (const std::string& n : opt->get_lnames()) out.insert("--" + n);
  }
  for (const CLI::App* sub : app.get_subcommands({})) CollectFlagNames(*sub, out);
}

}  // namespace

std::vector<std::string> NormalizeBooleanFlags(const CLI::App& app, std::vector<std::string> args) {
  std::set<std::string> flags;
  CollectFlagNames(app, flags);
  std::vector<std::string> out;
  out.reserve(args.size());
  for (std::size_t i = 0; i < args.size(); ++i) {
    if (args[i] == "--") {
      out.insert(out.end(), args.begin() + static_cast<std::ptrdiff_t>(i), args.end());
      break;
    }
    if (i + 1 < args.size() && flags.count(args[i]) > 0 && IsBooleanWord(args[i + 1])) {
      out.push_back(args[i] + "=" + args[i + 1]);
      ++i;
    } else {
      out.push_back(args[i]);
    }
  }
  return out;
}

void RequireNumbers(CLI::App& app) {
  for (CLI::Option* opt : app.get_options()) {
    if (opt->get_expected_max() == 0) continue;  // a flag without a value
    const std::string type = opt->get_type_name();
    const bool is_unsigned = type.rfind("UINT", 0) == 0;
    if (!is_unsigned && type.rfind("INT", 0) != 0 && type.rfind("FLOAT", 0) != 0) continue;
    // The description is empty so that the help's type stays "INT", "FLOAT".
    opt->check(CLI::Validator(
        [is_unsigned](std::string& v) -> std::string {
          const std::size_t first = v.find_first_not_of(" \t");
          if (first == std::string::npos) return "an empty value is not a number";
          if (is_unsigned && v[first] == '-') {
            return "'" + v + "': a negative value for a count or seed (0 or more)";
          }
          return std::string();
        },
        ""));
  }
  for (CLI::App* sub : app.get_subcommands([](CLI::App*) { return true; })) RequireNumbers(*sub);
}

}  // namespace aerovo::cli
