#include "red/sim/run.hpp"

#include <utility>

namespace red {

std::optional<PolicyOptions> policy_options(const Scenario& s, const std::string& policy,
                                            std::optional<SyncMode> sync) {
  auto o = preset_options(policy);
  if (!o) return std::nullopt;
  // Checked by check_policy_options (the CLI's load, simulate_policy, analyze, the DDS node)
  // and the CLI's --with; a bad entry would leave the preset unchanged.
  (void)apply_options(*o, s.scheduler.policy_with);
  if (sync) o->sync = *sync;
  return o;
}

Expected<Profile> resolve_profile(const Scenario& s, const std::optional<std::string>& cli_path,
                                  std::vector<std::string>* warnings) {
  Profile p;
  if (cli_path) {
    auto loaded = load_profile(*cli_path);
    if (!loaded) return loaded.error();
    p = std::move(loaded.value());
  } else if (!s.profile.empty()) {
    auto loaded = load_profile(s.profile);
    if (!loaded) return loaded.error();
    p = std::move(loaded.value());
  } else if (!s.model.manifest.empty()) {
    // The built-in profile holds MIMONet's costs: a user's model simulated on them, or
    // scheduled by them in a real run (deadlines, estimates), would be another model's.
    return Error{s.file, s.model.manifest_line > 0 ? s.model.manifest_line : s.model.line,
                 "model.manifest: the model '" + s.model.manifest +
                     "' has no profile, and the built-in one holds MIMONet's costs, not "
                     "its own: measure one (red profile --model " +
                     s.model.manifest + " --out P.json) and give it (profile: P.json in the " +
                     "scenario, or --profile P.json)"};
  } else {
    p = default_profile();
  }
  const ProfileIdentity id = check_profile_identity(p, s, cli_path);
  if (id.error) return *id.error;
  if (!id.warning.empty() && warnings != nullptr) warnings->push_back(id.warning);
  if (auto err = check_profile_covers(p, s)) return *err;
  return p;
}

}  // namespace red
