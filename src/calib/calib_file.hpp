// CALIB.toml for `biodem calibrate` (issue 9): the bulk-test cases run per evaluation, the
// measured targets, the parameters (bounds, the case keys each drives with a factor), the two
// objectives and the NSGA-II settings. Everything wrong with the file is reported here, naming
// the key, before any simulation runs. Format and meaning: docs/calibration.md.
#pragma once
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "calib/drum_test.hpp"

namespace biodem::calib {

struct CalibTest {
  std::string name;       // e.g. "heap"; runs go to DIR/runs/g<gen>/e<index>/<name>
  std::string case_path;  // resolved against the CALIB file's folder
  std::string case_text;  // the case with the base case merged in (TOML text)
  /// Set for a drum test (a case with [drum] and no bulk-test block; calib/drum_test.hpp): its
  /// responses come from the flowability analysis of its series, with these options.
  std::optional<DrumAnalysis> drum;
  /// `seeds = [s1, s2, ...]`: the test is run once per seed (its case's [run].seed set to it, in
  /// DIR/runs/.../<name>/seed<s>), and each of its responses is the mean over the runs (a response
  /// that one run lacks is missing). Empty: one run with the case's own seed, in .../<name>.
  std::vector<std::uint64_t> seeds;
};

struct CalibTarget {
  std::string response;  // a response of one of the tests (responses.csv)
  double value = 0.0;
  std::string unit;
};

struct CalibKey {
  std::string path;  // "pair.<material>.<material>.<key>"
  double factor = 1.0;
};

struct CalibParameter {
  std::string name;
  double lower = 0.0, upper = 0.0;
  std::vector<CalibKey> keys;
};

struct CalibObjective {
  std::vector<std::string> responses;  // relative errors to their targets, weighted mean
  std::vector<double> weights;
};

struct CalibConfig {
  std::string source_path;
  std::vector<CalibTest> tests;
  std::vector<CalibTarget> targets;
  std::vector<CalibParameter> parameters;
  CalibObjective o1, o2;
  std::uint64_t population = 8, generations = 2, seed = 1;
};

CalibConfig load_calib(const std::string& path);

/// The case text of `test` with every parameter's keys set to value x[k] x factor.
std::string apply_parameters(const CalibConfig& c, const CalibTest& test, const std::vector<double>& x);

/// The case text with its [run].seed set to `seed` (a [[test]]'s seeds).
std::string with_seed(const std::string& case_text, std::uint64_t seed);

/// The target of a response (throws if none).
const CalibTarget& target_of(const CalibConfig& c, const std::string& response);

}  // namespace biodem::calib
