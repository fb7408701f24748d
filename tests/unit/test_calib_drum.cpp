// Drum tests of a calibration campaign (calib/drum_test.hpp, docs/calibration.md "Drum tests"):
// the responses are the flowability descriptors of the run's series, a CALIB file with a drum
// test is checked before anything runs, and `calibrate --evaluate FILE` reads its vectors with
// a one-line error naming the file, line and column.
#include <gtest/gtest.h>
#include <vector>
#include <tuple>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "calib/calib_file.hpp"
#include "calib/drum_test.hpp"
#include "calib/evaluations_csv.hpp"
#include "core/error.hpp"
#include "test_util.hpp"

using namespace biodem;
using namespace biodem::testing;
namespace fs = std::filesystem;

namespace {

// A saw-tooth drum series: the bed turns with the drum at 1 rpm (6 deg/s) from 100 to 110 deg,
// then falls back to 100 deg within one sample: UAS 110 deg, drop 10 deg, one event every
// 10/6 s + one sample, i.e. f = rpm x T / 60 x 100 % of a revolution. r2 0.95 at every sample.
void write_sawtooth(const std::string& dir, int teeth) {
  fs::create_directories(dir);
  std::ostringstream s;
  s << "time_s,revolution,alpha_deg,surface_r2,kinetic_energy_j,contacts\n";
  const double dt = 0.01, rise_s = 10.0 / 6.0;
  double t = 0.0;
  for (int k = 0; k < teeth; ++k) {
    for (double a = 100.0; a <= 110.0 + 1e-9; a += 6.0 * dt, t += dt)
      s << t << ',' << t / 60.0 << ',' << a << ",0.95,0,0\n";
  }
  s << t << ',' << t / 60.0 << ",100,0.95,0,0\n";
  (void)rise_s;
  std::ofstream(dir + "/series.csv") << s.str();
}

std::string write(const std::string& dir, const std::string& name, const std::string& text) {
  std::ofstream(dir + "/" + name) << text;
  return dir + "/" + name;
}

// A CALIB folder with the quick base case and a drum case; `calib` is the CALIB file's text.
std::string calib_dir(const std::string& tag, const std::string& drum_case, const std::string& calib) {
  const std::string d = fresh_dir("calib_drum_" + tag);
  fs::create_directories(d);
  fs::copy_file(source_dir() + "/cases/calibration/quick/base.toml", d + "/base.toml");
  fs::copy_file(source_dir() + "/cases/calibration/quick/heap.toml", d + "/heap.toml");
  write(d, "drum.toml", drum_case);
  return write(d, "calib.toml", calib);
}

const char* kDrumCase = R"(
[insertion]
count = 250
[drum]
diameter_m = 0.030
width_m = 0.006
rpm = 15.0
mantle_material = "steel"
endplate_material = "steel"
[[phase]]
name = "settle"
steps = 100
[[phase]]
name = "rotate"
revolutions = 0.1
rotate = true
)";

const char* kParameters = R"(
[[parameter]]
name = "mu_s"
lower = 0.1
upper = 0.9
keys = ["pair.bead.bead.sliding_friction"]
[[parameter]]
name = "mu_r"
lower = 0.1
upper = 0.9
keys = ["pair.bead.bead.rolling_friction"]
)";

std::string drum_calib(const std::string& test_extra, const std::string& targets) {
  return std::string("[[test]]\nname = \"drum\"\ncase = \"drum.toml\"\nbase = \"base.toml\"\n") + test_extra + "\n" +
         targets + "\n[objectives]\no1 = [\"uas_deg_p50\"]\no2 = [\"event_count\"]\n" + kParameters;
}

const char* kDrumTargets = R"(
[[target]]
response = "uas_deg_p50"
value = 150.0
unit = "deg"
[[target]]
response = "event_count"
value = 5.0
unit = "-"
)";

std::string load_error(const std::string& path) {
  try {
    calib::load_calib(path);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST(CalibDrum, ResponsesAreTheDescriptorsOfTheSeries) {
  const std::string d = fresh_dir("calib_drum_sawtooth");
  write_sawtooth(d, 6);
  calib::DrumAnalysis a;
  a.min_drop_deg = 2.0;
  const calib::DrumMeasurement m = calib::measure_drum(d, a);
  EXPECT_TRUE(m.warnings.empty()) << m.warnings.front();
  // Six teeth: a drop at the end of each (the last one's at the last sample).
  EXPECT_EQ(m.responses.at("event_count"), 6.0);
  EXPECT_NEAR(m.responses.at("uas_deg_p50"), 110.0, 0.061);  // within one sample's rise (0.06 deg)
  EXPECT_NEAR(m.responses.at("uas_deg_mean"), 110.0, 0.061);
  EXPECT_NEAR(m.responses.at("drop_deg_p50"), 10.0, 0.061);
  // f: one tooth (10/6 s + one sample) of a 60 s revolution, in per cent.
  EXPECT_NEAR(m.responses.at("f_percent_p50"), (10.0 / 6.0 + 0.01) / 60.0 * 100.0, 0.02);
  EXPECT_NEAR(m.responses.at("surface_r2_p50"), 0.95, 1e-12);
  EXPECT_NEAR(m.responses.at("uas_deg_span"), 0.0, 1e-3);  // equal teeth
  EXPECT_EQ(m.responses.size(), calib::drum_response_names().size());
  for (const auto& n : calib::drum_response_names()) EXPECT_TRUE(m.responses.count(n)) << n;
  // The analysis files beside the series, as `biodem analyze` writes them, and responses.csv.
  EXPECT_TRUE(fs::exists(d + "/events.csv"));
  EXPECT_TRUE(fs::exists(d + "/descriptors.csv"));
  const auto csv = read_csv(d + "/responses.csv");
  ASSERT_EQ(csv.at("response").size(), calib::drum_response_names().size());
  for (std::size_t k = 0; k < csv.at("response").size(); ++k)
    EXPECT_EQ(csv.at("unit")[k], calib::drum_response_unit(csv.at("response")[k]));
  EXPECT_EQ(calib::drum_response_unit("uas_deg_p50"), "deg");
  EXPECT_EQ(calib::drum_response_unit("drop_deg_mean"), "deg");
  EXPECT_EQ(calib::drum_response_unit("f_percent_p90"), "%");
  EXPECT_EQ(calib::drum_response_unit("uas_deg_span"), "-");
  EXPECT_EQ(calib::drum_response_unit("surface_r2_p10"), "-");

  // A threshold above every drop: no events, the event descriptors are empty (NaN) and named.
  a.min_drop_deg = 20.0;
  const calib::DrumMeasurement none = calib::measure_drum(d, a);
  EXPECT_EQ(none.responses.at("event_count"), 0.0);
  EXPECT_TRUE(std::isnan(none.responses.at("uas_deg_p50")));
  EXPECT_NEAR(none.responses.at("surface_r2_p50"), 0.95, 1e-12);
  ASSERT_FALSE(none.warnings.empty());
  EXPECT_NE(none.warnings.front().find("no values of uas_deg, drop_deg, f_percent (0 events)"), std::string::npos)
      << none.warnings.front();
  EXPECT_EQ(none.warnings.size(), 1u);  // one line for the run, not one per descriptor

  // A folder without a series: no responses, a warning that says why.
  const calib::DrumMeasurement missing = calib::measure_drum(d + "/nothing", calib::DrumAnalysis{});
  EXPECT_TRUE(missing.responses.empty());
  ASSERT_EQ(missing.warnings.size(), 1u);
  EXPECT_NE(missing.warnings[0].find("cannot be analysed"), std::string::npos) << missing.warnings[0];
}

TEST(CalibDrum, JobLineCarriesTheAnalysisOptions) {
  EXPECT_EQ(calib::encode_drum_line(std::nullopt), "-");
  EXPECT_FALSE(calib::decode_drum_line("-").has_value());
  calib::DrumAnalysis a;
  a.min_drop_deg = 0.3;
  a.skip_rev = 0.25;
  const auto b = calib::decode_drum_line(calib::encode_drum_line(a));
  ASSERT_TRUE(b.has_value());
  EXPECT_EQ(*b->min_drop_deg, 0.3);
  EXPECT_FALSE(b->skip_s.has_value());
  EXPECT_EQ(*b->skip_rev, 0.25);
}

TEST(CalibDrum, CalibFileWithADrumTest) {
  // A drum test with analysis options; its responses are targets with their units.
  const auto c = calib::load_calib(calib_dir("good", kDrumCase, drum_calib("min_drop_deg = 0.3\nskip_s = 0.5", kDrumTargets)));
  ASSERT_EQ(c.tests.size(), 1u);
  ASSERT_TRUE(c.tests[0].drum.has_value());
  EXPECT_EQ(*c.tests[0].drum->min_drop_deg, 0.3);
  EXPECT_EQ(*c.tests[0].drum->skip_s, 0.5);
  EXPECT_FALSE(c.tests[0].drum->skip_rev.has_value());

  // What is refused, before anything runs, with the key named.
  EXPECT_NE(load_error(calib_dir("rad", kDrumCase,
                                 drum_calib("", std::string(kDrumTargets).replace(std::string(kDrumTargets).find("\"deg\""), 5, "\"rad\"")))).find(
                "[[target]] #1.unit = \"rad\": uas_deg_p50 is measured in \"deg\""),
            std::string::npos);
  EXPECT_NE(load_error(calib_dir("neg", kDrumCase, drum_calib("min_drop_deg = -1", kDrumTargets))).find("[[test]] #1.min_drop_deg"),
            std::string::npos);
  EXPECT_NE(load_error(calib_dir("both", kDrumCase, drum_calib("skip_s = 1\nskip_rev = 0.1", kDrumTargets)))
                .find("skip_s and skip_rev both given"),
            std::string::npos);
  std::string still = kDrumCase;  // (a phase in revolutions must turn: a duration)
  still.replace(still.find("revolutions = 0.1\nrotate = true"), 31, "duration_s = 0.01\nrotate = false");
  EXPECT_NE(load_error(calib_dir("still", still, drum_calib("", kDrumTargets))).find("a drum test needs a [[phase]] with rotate = true"),
            std::string::npos);
  std::string halted = kDrumCase;  // a turning phase of a drum at 0 rpm
  halted.replace(halted.find("rpm = 15.0"), 10, "rpm = 0.0");
  halted.replace(halted.find("revolutions = 0.1"), 17, "duration_s = 0.01");
  EXPECT_NE(load_error(calib_dir("halted", halted, drum_calib("", kDrumTargets))).find("a [drum].rpm other than 0"),
            std::string::npos)
      << load_error(calib_dir("halted", halted, drum_calib("", kDrumTargets)));
  // A response no test measures, and an analysis option on a bulk test.
  const std::string heap_calib =
      "[[test]]\nname = \"heap\"\ncase = \"heap.toml\"\nbase = \"base.toml\"\nmin_drop_deg = 0.3\n"
      "[[target]]\nresponse = \"angle_of_repose_deg\"\nvalue = 25.0\nunit = \"deg\"\n"
      "[objectives]\no1 = [\"angle_of_repose_deg\"]\no2 = [\"angle_of_repose_deg\"]\n" +
      std::string(kParameters);
  EXPECT_NE(load_error(calib_dir("bulk", kDrumCase, heap_calib)).find("[[test]] #1.min_drop_deg: an analysis option of drum tests"),
            std::string::npos);
  std::string heap_uas = heap_calib;
  heap_uas.replace(heap_uas.find("min_drop_deg = 0.3\n"), 19, "");
  const std::string aor_target = "response = \"angle_of_repose_deg\"\nvalue = 25.0\nunit = \"deg\"";
  heap_uas.replace(heap_uas.find(aor_target), aor_target.size(), "response = \"uas_deg_p50\"\nvalue = 150.0\nunit = \"deg\"");
  EXPECT_NE(load_error(calib_dir("nouas", kDrumCase, heap_uas)).find("\"uas_deg_p50\": no [[test]] case measures it"),
            std::string::npos);
}

TEST(CalibDrum, SeedsOfATestAndTheirErrors) {
  // `seeds`: one run per seed, in the order given; what is refused names the key.
  const auto c = calib::load_calib(calib_dir("seeds", kDrumCase, drum_calib("seeds = [4, 1, 9]", kDrumTargets)));
  ASSERT_EQ(c.tests.size(), 1u);
  EXPECT_EQ(c.tests[0].seeds, (std::vector<std::uint64_t>{4, 1, 9}));
  EXPECT_TRUE(calib::load_calib(calib_dir("noseeds", kDrumCase, drum_calib("", kDrumTargets))).tests[0].seeds.empty());
  for (const auto& [tag, extra, message] : std::vector<std::tuple<std::string, std::string, std::string>>{
           {"empty", "seeds = []", "[[test]] #1.seeds: an array of 1 to 64 seeds"},
           {"scalar", "seeds = 3", "[[test]] #1.seeds: an array of 1 to 64 seeds"},
           {"real", "seeds = [1, 2.0]", "[[test]] #1.seeds: each seed must be a non-negative integer"},
           {"negative", "seeds = [-1]", "[[test]] #1.seeds: each seed must be a non-negative integer"},
           {"twice", "seeds = [5, 6, 5]", "[[test]] #1.seeds: seed 5 given twice"}})
    EXPECT_NE(load_error(calib_dir("seeds_" + tag, kDrumCase, drum_calib(extra, kDrumTargets))).find(message),
              std::string::npos)
        << tag << ": " << load_error(calib_dir("seeds_" + tag, kDrumCase, drum_calib(extra, kDrumTargets)));
  // The case text of a seed: [run].seed set, added where the case has no [run].
  const std::string seeded = calib::with_seed(c.tests[0].case_text, 77);
  EXPECT_NE(seeded.find("seed = 77"), std::string::npos) << seeded;
  EXPECT_NE(calib::with_seed("[insertion]\ncount = 5\n", 3).find("seed = 3"), std::string::npos);
}

// What a calibration file may not say, each a one-line error naming the key (before, each was
// accepted: a nan target scored every evaluation 1e9 and ended "done"; a parameter named index
// made --evaluate read the index column; two parameters on one key left the first a dead
// dimension; a second target was ignored; zero weights made o1 0 for all; seed 2^32 + 5 ran the
// search of seed 5; a population of 4e12 failed with bad_alloc after the folder was made).
TEST(CalibDrum, CalibrationFileMistakesAreOneLineErrors) {
  const std::string good = drum_calib("", kDrumTargets);
  auto with = [&](std::string text, const std::string& from, const std::string& to) {
    const auto at = text.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    if (at != std::string::npos) text.replace(at, from.size(), to);
    return text;
  };
  const std::vector<std::tuple<std::string, std::string, std::string>> cases = {
      {"nan", with(good, "value = 150.0", "value = nan"), "[[target]] #1.value: must be a finite number"},
      {"inf", with(good, "lower = 0.1", "lower = -inf"), "[[parameter]] #1.lower: must be a finite number"},
      {"index", with(good, "name = \"mu_s\"", "name = \"index\""), "[[parameter]] #1.name = \"index\": is a column"},
      {"wall", with(good, "name = \"mu_r\"", "name = \"wall_s\""), "[[parameter]] #2.name = \"wall_s\": is a column"},
      {"response", with(good, "name = \"mu_s\"", "name = \"event_count\""), "is a response's column"},
      {"samekey", with(good, "pair.bead.bead.rolling_friction", "pair.bead.bead.sliding_friction"),
       "[[parameter]] #2.keys: \"pair.bead.bead.sliding_friction\" is set by parameter \"mu_s\" already"},
      {"twotargets", good + "[[target]]\nresponse = \"event_count\"\nvalue = 7.0\nunit = \"\"\n",
       "[[target]] #3.response = \"event_count\": has a target already"},
      {"zeroweights", with(good, "o1 = [\"uas_deg_p50\"]", "o1 = [\"uas_deg_p50\"]\no1_weights = [0.0]"),
       "[objectives].o1_weights: at least one weight must be positive"},
      {"bigseed", "[campaign]\nseed = 4294967301\n" + good, "[campaign].seed = 4294967301: at most 4294967295"},
      {"bigpop", "[campaign]\npopulation = 4000000000000\n" + good, "[campaign].population = 4000000000000: at most 100000"},
  };
  for (const auto& [tag, text, message] : cases) {
    const std::string e = load_error(calib_dir("mistake_" + tag, kDrumCase, text));
    EXPECT_NE(e.find(message), std::string::npos) << tag << ": " << e;
    EXPECT_EQ(e.find('\n'), std::string::npos) << tag << ": " << e;
  }
  EXPECT_NO_THROW(calib::load_calib(calib_dir("mistake_none", kDrumCase, good)));
}

TEST(CalibDrum, EvaluateFileRowsAndItsErrors) {
  const auto c = calib::load_calib(calib_dir("rows", kDrumCase, drum_calib("", kDrumTargets)));
  const std::string d = fresh_dir("calib_drum_rows_files");
  fs::create_directories(d);
  // A pareto.csv: other columns are ignored, the parameters are found by name in any order.
  const auto rows = calib::read_parameter_rows(
      write(d, "pareto.csv", "generation,index,mu_r,mu_s,angle_of_repose_deg,o1,o2,wall_s\n4,8,0.3,0.7,14.8,0.01,0.02,0.9\n"
                             "4,4,0.8,0.9,15.1,0.03,0,0.8\n"),
      c);
  ASSERT_EQ(rows.size(), 2u);
  EXPECT_EQ(rows[0], (std::vector<double>{0.7, 0.3}));
  EXPECT_EQ(rows[1], (std::vector<double>{0.9, 0.8}));
  auto error = [&](const std::string& text) {
    try {
      calib::read_parameter_rows(write(d, "bad.csv", text), c);
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_NE(error("mu_s,o1\n0.5,1\n").find("bad.csv: no column \"mu_r\""), std::string::npos);
  EXPECT_NE(error("mu_s,mu_r\n0.5,abc\n").find("bad.csv line 2, column mu_r: \"abc\" is not a number"), std::string::npos);
  EXPECT_NE(error("mu_s,mu_r\n0.5,0.5\n0.95,0.5\n").find("line 3, column mu_s = 0.95: outside the parameter's bounds [0.1, 0.9]"),
            std::string::npos)
      << error("mu_s,mu_r\n0.5,0.5\n0.95,0.5\n");
  EXPECT_NE(error("mu_s,mu_r\n").find("no rows to evaluate"), std::string::npos);
  EXPECT_NE(error("mu_s,mu_r\n0.5\n").find("line 2, column mu_r: missing"), std::string::npos);
  EXPECT_NE(error("").find("empty file"), std::string::npos);
  // As a spreadsheet writes it: a byte order mark, quoted cells, CRLF, blank and comment lines.
  const auto sheet = calib::read_parameter_rows(
      write(d, "sheet.csv", "\xEF\xBB\xBF\"mu_s\",\"mu_r\"\r\n# from the bulk campaign\r\n\"0.5\",0.25\r\n\r\n 0.6 , 0.35 \r\n"), c);
  ASSERT_EQ(sheet.size(), 2u);
  EXPECT_EQ(sheet[0], (std::vector<double>{0.5, 0.25}));
  EXPECT_EQ(sheet[1], (std::vector<double>{0.6, 0.35}));
  EXPECT_NE(error("mu_s;mu_r\n0.5;0.5\n").find("in the header \"mu_s;mu_r\" (line 1)"), std::string::npos)
      << error("mu_s;mu_r\n0.5;0.5\n");
}
