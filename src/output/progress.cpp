#include "output/progress.hpp"

#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <sstream>

namespace biodem::output {

std::string format_duration(double s) {
  if (!std::isfinite(s) || s < 0) return "--:--";
  const long t = static_cast<long>(std::lround(s));
  char buf[32];
  if (t >= 3600) std::snprintf(buf, sizeof buf, "%ld:%02ld:%02ld", t / 3600, (t / 60) % 60, t % 60);
  else std::snprintf(buf, sizeof buf, "%02ld:%02ld", t / 60, t % 60);
  return buf;
}

Progress::Progress(std::ostream& out, bool tty, double interval)
    : out_(out), tty_(tty), interval_s_(interval), start_(std::chrono::steady_clock::now()), last_(start_) {}

bool Progress::stderr_is_terminal() { return isatty(STDERR_FILENO) != 0; }

void Progress::update(double f, const std::string& label, double sim_time_s) {
  const auto now = std::chrono::steady_clock::now();
  const double since = std::chrono::duration<double>(now - last_).count();
  if (since < (tty_ ? 0.25 : interval_s_) && f < 1.0) return;
  last_ = now;
  const double elapsed = std::chrono::duration<double>(now - start_).count();
  const double eta = f > 1e-6 ? elapsed * (1.0 - f) / f : -1.0;
  std::ostringstream o;
  o.setf(std::ios::fixed);
  o.precision(1);
  if (tty_) {
    const int width = 30, filled = static_cast<int>(f * width);
    o << "\r[" << std::string(filled, '#') << std::string(width - filled, '-') << "] " << 100.0 * f << "% "
      << label << " t=" << sim_time_s << " s  elapsed " << format_duration(elapsed) << "  ETA "
      << format_duration(eta) << "   ";
    out_ << o.str() << std::flush;
    drawn_ = true;
  } else {
    o << "progress " << 100.0 * f << "% (" << label << ", t = " << sim_time_s << " s), elapsed "
      << format_duration(elapsed) << ", ETA " << format_duration(eta) << "\n";
    out_ << o.str() << std::flush;
  }
}

void Progress::finish(const std::string& message) {
  if (tty_ && drawn_) out_ << "\n";
  out_ << message << "\n" << std::flush;
}

}  // namespace biodem::output
