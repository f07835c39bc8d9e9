// libFuzzer target: JSON run configuration files (aerovo::ParseRunConfig, what LoadRunConfig and
// `aerovo run --config` use), followed by Validate as the CLI does.
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "aerovo/core/error.h"
#include "aerovo/pipeline/runner.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  try {
    const aerovo::RunConfig config =
        aerovo::ParseRunConfig(text, aerovo::RunConfigFormat::kJson, aerovo::RunConfig{}, "fuzz");
    aerovo::Validate(config);
    // A valid configuration survives its own round trip through JSON (what `aerovo run --config
    // OUT/config.json` relies on): the same configuration comes back.
    const aerovo::RunConfig back =
        aerovo::RunConfigFromJson(aerovo::ToJson(config), aerovo::RunConfig{}, "round trip");
    if (aerovo::ToJson(back) != aerovo::ToJson(config)) __builtin_trap();
  } catch (const aerovo::InputError&) {
  } catch (const aerovo::InvalidArgument&) {
  }
  return 0;
}
