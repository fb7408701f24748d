// Progress reporting for long runs: a bar with percentage, simulated time and ETA redrawn in
// place on a terminal; plain periodic lines otherwise (logs, CI).
#pragma once
#include <chrono>
#include <cstdint>
#include <ostream>
#include <string>

namespace biodem::output {

class Progress {
 public:
  /// `tty`: draw a bar; otherwise a line every `line_interval_s` of wall time.
  Progress(std::ostream& out, bool tty, double line_interval_s = 10.0);
  /// fraction in [0, 1] of the whole run; `label` e.g. the phase name.
  void update(double fraction, const std::string& label, double sim_time_s);
  void finish(const std::string& message);
  static bool stderr_is_terminal();

 private:
  std::ostream& out_;
  bool tty_;
  double interval_s_;
  std::chrono::steady_clock::time_point start_, last_;
  bool drawn_ = false;
};

std::string format_duration(double seconds);

}  // namespace biodem::output
