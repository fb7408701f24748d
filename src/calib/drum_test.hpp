// Drum tests of a calibration campaign (docs/calibration.md, "Drum tests"): a [[test]] whose case
// is a rotating drum (a [drum] and a phase with rotate = true, no bulk-test block). After the run,
// the flowability analysis of `biodem analyze` (SPEC 6) runs on its series.csv; the test's
// responses are the descriptors' statistics (uas_deg_p50, drop_deg_mean, f_percent_span,
// surface_r2_p10, ...) and event_count, so that a campaign can match a drum measured on the real
// instrument (a video analysed by `biodem video` and `biodem analyze`), or narrow a bulk-test
// Pareto set by the drum (SPEC 7).
#pragma once
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace biodem::calib {

/// The analysis options of a drum test ([[test]] keys; `biodem analyze`'s options of the same
/// names). Absent: analyze's defaults.
struct DrumAnalysis {
  std::optional<double> min_drop_deg, skip_s, skip_rev;
};

/// The responses a drum test produces: <descriptor>_<statistic> for the descriptors uas_deg,
/// drop_deg, f_percent, surface_r2 and the statistics mean, p10, p50, p90, span; and event_count.
const std::vector<std::string>& drum_response_names();

/// The unit of a drum response, as written in responses.csv: deg (uas_deg_*, drop_deg_*), %
/// (f_percent_*), - (surface_r2_*, every *_span, which is (p90 - p10) / (p90 + p10), and
/// event_count).
std::string drum_response_unit(const std::string& response);

struct DrumMeasurement {
  std::map<std::string, double> responses;  // NaN where a distribution is empty
  std::vector<std::string> warnings;         // "WARNING: ..." lines for campaign.log
};

/// Analyses `out_dir`/series.csv as `biodem analyze` does with `a`, writes events.csv,
/// descriptors.csv and responses.csv (response,value,unit) beside it, and returns the responses.
/// A series that cannot be analysed (too few samples, no rotation) gives no responses and a
/// warning naming the reason; so do descriptors without values (no events), each by name.
DrumMeasurement measure_drum(const std::string& out_dir, const DrumAnalysis& a);

/// One line for an MPI job message ("-" without a drum test) and back.
std::string encode_drum_line(const std::optional<DrumAnalysis>& a);
std::optional<DrumAnalysis> decode_drum_line(const std::string& line);

}  // namespace biodem::calib
