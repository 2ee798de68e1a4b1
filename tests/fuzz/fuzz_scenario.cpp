// libFuzzer target: scenario YAML text -> parse_scenario (parsing and validation,
// docs/SCENARIOS.md). A scenario that validates is then simulated briefly (fuzz_support.hpp).

#include <cstddef>
#include <cstdint>
#include <string>

#include "fuzz_support.hpp"
#include "red/scenario/loader.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  red::Expected<red::Scenario> s = red::parse_scenario(text, "fuzz.yaml");
  if (!s) {
    // Every rejection names the file and says what is wrong.
    if (s.error().file != "fuzz.yaml" || s.error().message.empty())
      red::fuzz::fail("error without file or message");
    return 0;
  }
  red::fuzz::simulate_if_small(*s);
  return 0;
}
