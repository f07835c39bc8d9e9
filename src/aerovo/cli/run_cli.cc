#include "aerovo/cli/run_cli.h"

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <type_traits>
#include <utility>

#include <fmt/format.h>

#include "aerovo/cli/conventions.h"
#include "aerovo/core/options_json.h"

namespace aerovo::cli {
namespace {

std::atomic<bool> g_stop{false};
volatile std::sig_atomic_t g_signal = 0;

extern "C" void OnStopSignal(int sig) {
  if (g_signal == 0) g_signal = sig;  // the first one is the cause reported
  g_stop.store(true);  // lock-free on every platform we build for: async-signal-safe
}

// The CLI11 binder of the option schema: one option per name of a field (its key, its legacy
// alias, a shorthand whose first key it is); each writes the given value into RunFlags::given
// under that name (enums as their names, checked by CLI::IsMember).
class FlagBinder : public options::GroupingVisitor<FlagBinder> {
 public:
  FlagBinder(CLI::App* cmd, RunFlags& flags, const std::set<std::string>& skip)
      : cmd_(cmd), flags_(flags), skip_(skip) {}

  template <class T>
  void Field(const T& value, const char* key, const char* doc, const options::Spec& spec) {
    const std::string k = Key(key);
    if (skip_.count(k) > 0 || (spec.alias && skip_.count(spec.alias) > 0)) return;
    std::string names = options::FlagName(k);
    if (spec.extra_flags) names = std::string(spec.extra_flags) + "," + names;
    std::string help = doc;
    if (spec.HasRange()) help += " (" + spec.Describe() + ")";
    if (!spec.alias) {
      Add(names, k, help, value, StageGroup(k));
    } else {
      Add(names, k, help + "; also --" + Dashed(spec.alias), value, StageGroup(k));
      Add(options::FlagName(spec.alias), spec.alias, help + " (= " + options::FlagName(k) + ")",
          value, kRunGroup);
    }
    for (const RunShorthand& s : RunShorthands()) {
      if (s.keys.front() != k || skip_.count(s.name) > 0) continue;
      std::string sets;
      for (const char* t : s.keys) sets += (sets.empty() ? "" : " and ") + options::FlagName(t);
      Add(options::FlagName(s.name), s.name, std::string(s.doc) + " (sets " + sets + ")", value,
          kRunGroup);
    }
  }

 private:
  static constexpr const char* kRunGroup = "Options";  // CLI11's default group: listed first

  static std::string Dashed(const std::string& key) { return options::FlagName(key).substr(2); }

  // The help group of a key: the run's own options first, then one group per stage.
  static std::string StageGroup(const std::string& key) {
    const std::string group = key.substr(0, key.find('.'));
    if (group == key) return kRunGroup;
    static const std::pair<const char*, const char*> kTitles[] = {
        {"flat_field", "Flat field"},
        {"surf", "SURF"},
        {"match", "Matching"},
        {"ransac", "RANSAC"},
        {"clustered", "Clustered RANSAC"},
        {"correspondence", "Correspondence"},
        {"odometry", "Odometry"}};
    for (const auto& [name, title] : kTitles) {
      if (group == name) return std::string(title) + " (" + name + ".*)";
    }
    return group;
  }

  template <class T>
  void Add(const std::string& names, const std::string& json_key, const std::string& help,
           const T& value, const std::string& group) {
    nlohmann::json& given = flags_.given;
    CLI::Option* opt = nullptr;
    if constexpr (std::is_same_v<T, bool>) {
      // One boolean style everywhere: `--X` sets, `--no-X` clears, `--X=false` (true/false,
      // 1/0, on/off, yes/no) sets a value; the last one given wins. (`--X 0`, the style of
      // earlier versions, is rewritten to `--X=0` before parsing: NormalizeBooleanFlags.)
      std::string all = names;
      std::string rest = names;
      while (!rest.empty()) {
        const std::string name = rest.substr(0, rest.find(','));
        rest = name.size() < rest.size() ? rest.substr(name.size() + 1) : std::string();
        if (name.rfind("--", 0) == 0) all += ",!" + options::NegatedFlagName(name);
      }
      opt = cmd_->add_flag_function(
          all, [&given, json_key](std::int64_t v) { given[json_key] = v > 0; }, help);
      opt->check(BooleanWord())->multi_option_policy(CLI::MultiOptionPolicy::TakeLast);
      opt->default_str(value ? "true" : "false");
    } else if constexpr (std::is_same_v<T, std::vector<std::string>>) {
      // A list: the flag once per element (`--map a.tif --map b.tif`), in the order given.
      opt = cmd_->add_option_function<std::vector<std::string>>(
          names, [&given, json_key](const T& v) { given[json_key] = options::ToJsonValue(v); },
          help);
      opt->allow_extra_args(false)->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
    } else if constexpr (std::is_enum_v<T>) {
      opt = cmd_->add_option_function<std::string>(
          names, [&given, json_key](const std::string& v) { given[json_key] = v; }, help);
      opt->check(CLI::IsMember(options::EnumNames<T>()))->default_str(options::EnumName(value));
    } else {
      opt = cmd_->add_option_function<T>(
          names, [&given, json_key](const T& v) { given[json_key] = options::ToJsonValue(v); },
          help);
      if constexpr (std::is_same_v<T, std::string>) {
        opt->default_str(value);
      } else {
        opt->default_str(options::FormatNumber(value));
      }
    }
    opt->group(group);
  }

  // The values a boolean flag accepts after '=' (CLI11 would otherwise throw from stoll on
  // `--guided=maybe`); its description is empty so the help stays one line per flag.
  static CLI::Validator BooleanWord() {
    return CLI::Validator(
        [](std::string& v) -> std::string {
          return IsBooleanWord(v) ? std::string()
                                  : "'" + v + "' is not a boolean (true/false, 1/0, on/off, yes/no)";
        },
        "");
  }

  CLI::App* cmd_;
  RunFlags& flags_;
  const std::set<std::string>& skip_;
};

}  // namespace

RunConfig RunFlags::Resolve() const {
  RunConfig config = paper ? PaperRunConfig() : RunConfig{};
  if (!config_file.empty()) config = LoadRunConfig(config_file, config);
  return RunConfigFromJson(given, config, "command line");
}

void AddRunFlags(CLI::App* cmd, RunFlags& a, const std::set<std::string>& skip) {
  cmd->add_option("--config", a.config_file,
                  "JSON or YAML (.yaml/.yml) file with any of the options below (keys as in the "
                  "saved config.json, which it accepts as it is; aerovo run --list-options lists "
                  "them); flags given on the command line win");
  cmd->add_flag("--paper", a.paper,
                "The paper's exact pipeline: fixed SURF threshold (MATLAB), no guided matching, no "
                "refinement (docs/options.md, Presets); options given with it still win");
  FlagBinder binder(cmd, a, skip);
  const RunConfig defaults;
  options::Visit(defaults, binder);
}

StopSignals::StopSignals() {
  g_stop.store(false);
  g_signal = 0;
  struct sigaction sa {};
  sa.sa_handler = OnStopSignal;
  sigemptyset(&sa.sa_mask);
  // No SA_RESTART: a blocking read returns and the loop sees the flag. SA_RESETHAND: the next
  // signal of the same kind takes the default action (kills).
  sa.sa_flags = SA_RESETHAND;
  sigaction(SIGINT, &sa, &old_int_);
  sigaction(SIGTERM, &sa, &old_term_);
  sigaction(SIGHUP, &sa, &old_hup_);  // the terminal went away (a dropped SSH session)
  // SIGPIPE (the reader of stdout went away, `aerovo run --print-poses | head`): stop, and
  // without SA_RESETHAND, so that later writes to the closed pipe fail with EPIPE (ignored by
  // the streams) instead of killing the run before its summary is written.
  sa.sa_flags = 0;
  sigaction(SIGPIPE, &sa, &old_pipe_);
}

StopSignals::~StopSignals() {
  sigaction(SIGINT, &old_int_, nullptr);
  sigaction(SIGTERM, &old_term_, nullptr);
  sigaction(SIGHUP, &old_hup_, nullptr);
  // A closed stdout must not kill the process while it prints its last lines: EPIPE instead.
  if (g_signal == SIGPIPE) {
    ::signal(SIGPIPE, SIG_IGN);
  } else {
    sigaction(SIGPIPE, &old_pipe_, nullptr);
  }
}

const std::atomic<bool>* StopSignals::stop() const { return &g_stop; }
int StopSignals::signal() const { return static_cast<int>(g_signal); }

std::string StopSignals::Name(int signal) {
  if (signal == SIGINT) return "SIGINT";
  if (signal == SIGTERM) return "SIGTERM";
  if (signal == SIGHUP) return "SIGHUP (the terminal closed)";
  if (signal == SIGPIPE) return "SIGPIPE (the reader of the output closed it)";
  return "signal " + std::to_string(signal);
}

int StopSignals::ExitCode(int signal) { return 128 + (signal > 0 ? signal : SIGINT); }

}  // namespace aerovo::cli
