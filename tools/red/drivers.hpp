#pragma once
/// \file
/// How run_policies runs a policy: in the simulator (SimDriver) or on a real backend through the
/// real-time runtime (RealDriver), chosen once by make_driver (drivers.cpp).

#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "common.hpp"
#include "real_run.hpp"
#include "red/metrics/metrics.hpp"
#include "red/metrics/policy_run.hpp"
#include "red/report/html.hpp"
#include "run_policies.hpp"

namespace red::cli {

// What differs between running the policies in the simulator and on a real backend (the
// real-time runtime); run_policies chooses one of the two once (make_driver) and does the rest
// the same way for both.
class Driver {
 public:
  virtual ~Driver() = default;
  /// The lanes are asynchronous (they hold a queue of units).
  [[nodiscard]] virtual bool asynchronous() const { return false; }
  /// Rows are streamed to jobs.csv and units.csv as jobs end (set_rows), not kept in memory.
  [[nodiscard]] virtual bool streams_rows() const { return false; }
  virtual void set_rows(RowSink* /*rows*/) {}
  /// The backend in the table's heading, and in summary.json.
  [[nodiscard]] virtual std::string heading_name() const = 0;
  [[nodiscard]] virtual std::string summary_name() const = 0;
  /// Said on stderr before policy `i` of `count` starts.
  virtual void announce(const std::string& /*policy*/, std::size_t /*i*/, std::size_t /*count*/) {}
  virtual Expected<PolicyRun> run(const std::string& policy, const std::vector<Observer*>& extra,
                                  bool keep_units) = 0;
  /// The exit code when a run fails.
  [[nodiscard]] virtual int failure_code() const = 0;
  /// After `policy` ran: its line on stderr, and what is kept of it for later.
  virtual void finished(const std::string& policy, const PolicyRun& r) = 0;
  /// The simulator's prediction of the runs, printed (prediction.json's text; "": none).
  virtual std::string predict(const std::vector<PolicyRun>& /*runs*/,
                              std::vector<HtmlTable>& /*html*/) {
    return {};
  }
  /// The run's own costs as a calibrated profile (`--write-profile`; a real backend only).
  [[nodiscard]] virtual Expected<Profile> own_costs_profile(
      const std::vector<PolicyRun>& /*runs*/) const {
    return Error{"", 0, "--write-profile is for a real run (--backend torch or synthetic)"};
  }
  /// The files write_more writes (index.html links them).
  virtual void more_files(OutputOptions& /*o*/, const std::string& /*prediction*/) const {}
  /// Writes the files besides write_outputs' through `put(name, text)`.
  virtual void write_more(
      const std::vector<std::string>& /*names*/, const std::string& /*prediction*/,
      const std::string& /*run_id*/,
      const std::function<void(const std::string&, const std::string&)>& /*put*/) const {}
};

// The driver for `a.backend`, or the error that stops the command before any run (exit 2).
Expected<std::unique_ptr<Driver>> make_driver(const RunArgs& a, const Scenario& s, const Profile& p,
                                              std::uint64_t seed, RealRunOptions real);

}  // namespace red::cli
