#include "output/analysis_files.hpp"

#include <filesystem>
#include <sstream>

#include "analysis/distributions.hpp"
#include "output/output_dir.hpp"
#include "output/series_csv.hpp"

namespace biodem::output {

// (A file that cannot be removed, in a read-only folder, is left: the new files written next
// then fail with a one-line error naming the file.)
void remove_analysis_plots(const std::string& dir) {
  std::error_code ec;
  for (const char* stem : kAnalysisPlots)
    for (const char* ext : {".png", ".svg"}) std::filesystem::remove(std::filesystem::path(dir) / (std::string(stem) + ext), ec);
}

void remove_analysis_outputs(const std::string& dir) {
  std::error_code ec;
  for (const char* f : kAnalysisTables) std::filesystem::remove(std::filesystem::path(dir) / f, ec);
  remove_analysis_plots(dir);
}

void write_events_csv(const std::string& path, const analysis::FlowabilityResult& r) {
  std::ostringstream out;
  out << "start_time_s,start_revolution,uas_deg,end_time_s,drop_deg,interval_s,f_percent\n";
  for (const auto& e : r.detection.events) {
    out << csv_number(e.start_time_s, 12) << ',' << csv_number(e.start_revolution, 12) << ','
        << csv_number(e.uas_deg) << ',' << csv_number(e.end_time_s, 12) << ',' << csv_number(e.drop_deg) << ','
        << (e.interval_s ? csv_number(*e.interval_s, 12) : "") << ',' << (e.f_percent ? csv_number(*e.f_percent) : "")
        << '\n';
  }
  write_file_atomic(path, out.str());
}

void write_descriptors_csv(const std::string& path, const analysis::FlowabilityResult& r) {
  std::ostringstream out;
  out << "descriptor,count,mean,p10,p50,p90,span\n";
  const auto table = analysis::descriptor_table();
  for (std::size_t k = 0; k < table.size(); ++k) {
    const auto& d = r.distributions[k];
    out << table[k].name << ',' << d.count << ',' << csv_number(d.mean) << ',' << csv_number(d.p10) << ','
        << csv_number(d.p50) << ',' << csv_number(d.p90) << ',' << csv_number(d.span) << '\n';
  }
  write_file_atomic(path, out.str());
}

}  // namespace biodem::output
