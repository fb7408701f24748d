// `biodem calibrate CALIB.toml --out DIR [--jobs N] [--resume] [--evaluate FILE]` (SPEC 7, 11;
// issue 9): an NSGA-II campaign over case parameters, run by the campaign library
// (calib/campaign.hpp): each evaluation runs the CALIB file's test cases (bulk tests, drum tests)
// as child processes of this binary, --jobs N at once, or on MPI ranks under mpirun. With
// --evaluate, no search: the vectors of FILE's rows are evaluated (narrowing a Pareto set).
#include <iostream>
#include <string>

#include "commands.hpp"
#ifdef BIODEM_HAVE_PAGMO
#include "calib/campaign.hpp"
#endif

namespace biodem::cli {

Action register_calibrate(CLI::App& app) {
  auto* sub = app.add_subcommand("calibrate", kCalibrateSummary);
  static std::string calib_path, out_dir;
  static int jobs = 1;
  static bool resume = false;
  static std::string evaluate_csv;
  sub->add_option("CALIB", calib_path, "calibration file (TOML)")->required();
  sub->add_option("--out", out_dir, "output directory")->required();
  sub->add_option("--jobs", jobs, "evaluations run at once on this machine (child processes)")
      ->check(whole_number_at_least(1));
  sub->add_flag("--resume", resume, "re-use the finished evaluations of an interrupted campaign in --out");
  sub->add_option("--evaluate", evaluate_csv,
                  "no search: evaluate the parameter vectors of this CSV file's rows (columns named as the "
                  "parameters, e.g. an earlier campaign's pareto.csv, to narrow it with a drum test)");
  return [] {
#ifdef BIODEM_HAVE_PAGMO
    calib::CampaignOptions o;
    o.out_dir = out_dir;
    o.jobs = jobs;
    o.resume = resume;
    o.evaluate_csv = evaluate_csv;
    calib::CampaignSummary s;
    try {
      s = calib::calibrate(calib_path, o);
    } catch (const calib::CampaignStopped& e) {
      std::cerr << e.what() << "\n";
      return 128 + e.signal;  // 130 for SIGINT, 143 for SIGTERM, as `run`
    }
    if (!s.mpi_worker)
      std::cout << "calibrate: done; " << s.pareto << " Pareto points in " << out_dir << "/pareto.csv\n";
    return 0;
#else
    std::cerr << "biodem: error: calibrate is not built (pagmo, libpagmo-dev, was not found at build time)\n";
    return 2;
#endif
  };
}

}  // namespace biodem::cli
