#pragma once
/// \file
/// The model manifest (YAML) of a user's TorchScript multi-task model (docs/MODELS.md):
///
///     encoder: encoder.pt          # TorchScript file, relative to the manifest's directory
///     heads: {lane: lane.pt, seg: seg.pt}
///     input: [3, 128, 256]         # C, H, W of one frame
///     outputs: tuple               # optional: tensor | tuple | list
///
/// The encoder takes one tensor [B, C, H, W] and returns a tensor or a tuple/list of
/// tensors; each head takes what the encoder returned, in the same form, and returns a
/// tensor.

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "red/core/expected.hpp"
#include "red/scenario/scenario.hpp"

namespace red {

/// How a TorchScript encoder returns its features.
enum class FeatureForm : std::uint8_t { Tensor, Tuple, List };

/// "tensor", "tuple" or "list".
const char* to_string(FeatureForm form) noexcept;

/// One TorchScript file named by a manifest.
struct ManifestFile {
  std::string name;  ///< head name (empty for the encoder)
  std::string path;  ///< resolved against the manifest's directory
  int line = 0;      ///< line of its key in the manifest
};

/// A parsed, checked manifest. Every file it names exists (not yet loaded).
struct ModelManifest {
  std::string file;  ///< the manifest's own path, as given
  ManifestFile encoder;
  std::vector<ManifestFile> heads;  ///< in file order
  std::vector<std::int64_t> input;  ///< C, H, W, all > 0
  int input_line = 0;
  std::optional<FeatureForm> outputs;  ///< as declared; empty: whatever the encoder returns
  int outputs_line = 0;
};

/// Reads and checks a manifest: a mapping with exactly the keys encoder, heads, input and
/// optionally outputs; head names of letters, digits, '_' or '-'; files that exist.
/// Errors carry the manifest's path and the line of the offending key or value.
Expected<ModelManifest> load_manifest(const std::string& path);

/// Same from text: `path` stands for the manifest's own path (messages name it; relative
/// file names resolve against its directory). Needs no LibTorch (fuzzed, tests/fuzz).
Expected<ModelManifest> parse_manifest(const std::string& yaml_text, const std::string& path);

/// Checks a scenario's model against what a run of it needs, without running anything
/// (`red validate` and every command that loads a scenario call it after the loader). For a
/// manifest model: the manifest exists (else an error at the scenario's `manifest:` line)
/// and loads (its errors keep the manifest's file and line, including a TorchScript file it
/// names that does not exist), every head the scenario lists is one of the manifest's (an
/// error at the head's line in the scenario), and the scenario's `input` equals the
/// manifest's; a scenario that gives no `input` takes the manifest's into `s.model.input`.
/// A built-in model needs nothing more. `manifest`, when given, receives the loaded
/// manifest (left empty for a built-in model).
std::optional<Error> check_model(Scenario& s, std::optional<ModelManifest>* manifest = nullptr);

}  // namespace red
