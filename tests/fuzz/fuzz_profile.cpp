// libFuzzer target: profile JSON text -> parse_profile (docs/DESIGN.md, "Profiles"). A profile that
// parses must survive a round trip: profile_to_json, parsed again, gives the same JSON.

#include <cstddef>
#include <cstdint>
#include <string>

#include "fuzz_support.hpp"
#include "red/profile/profile.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  red::Expected<red::Profile> p = red::parse_profile(text, "fuzz.json");
  if (!p) {
    if (p.error().file != "fuzz.json" || p.error().message.empty())
      red::fuzz::fail("error without file or message");
    return 0;
  }
  const std::string once = red::profile_to_json(*p);
  red::Expected<red::Profile> again = red::parse_profile(once, "again.json");
  if (!again) red::fuzz::fail("a written profile does not parse");
  if (red::profile_to_json(*again) != once) red::fuzz::fail("profile round trip differs");
  return 0;
}
