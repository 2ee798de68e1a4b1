// libFuzzer target: model manifest YAML text -> parse_manifest (the core's manifest
// reader, red/scenario/manifest.hpp). The manifest "lives" in a scratch directory holding
// the TorchScript file names the seeds use, so inputs get past the file checks.

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>

#include "fuzz_support.hpp"
#include "red/scenario/manifest.hpp"

namespace {

std::string scratch_manifest() {
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / "red-fuzz-manifest";
  fs::create_directories(dir);
  for (const char* name : {"encoder.pt", "lane.pt", "seg.pt", "steer.pt", "det.pt"})
    std::ofstream(dir / name) << "not a real module\n";
  return (dir / "model.yaml").string();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const std::string path = scratch_manifest();
  const std::string text(reinterpret_cast<const char*>(data), size);
  auto m = red::parse_manifest(text, path);
  if (!m) {
    if (m.error().file != path || m.error().message.empty())
      red::fuzz::fail("error without file or message");
    return 0;
  }
  if (m->heads.empty() || m->input.size() != 3) red::fuzz::fail("accepted an incomplete manifest");
  for (std::int64_t n : m->input)
    if (n <= 0) red::fuzz::fail("accepted a non-positive input size");
  return 0;
}
