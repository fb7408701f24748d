#include "calib/evaluations_csv.hpp"

#include <cstdio>
#include <fstream>
#include <sstream>

#include "calib/objectives.hpp"

namespace biodem::calib {
namespace {

std::string g17(double v) {
  char b[40];
  std::snprintf(b, sizeof b, "%.17g", v);
  return b;
}

}  // namespace

// Fields are appended piecewise: "," + std::string trips a GCC 12 -Wrestrict false positive.
std::string evaluations_header(const CalibConfig& c) {
  std::string h = "generation,index";
  for (const auto& p : c.parameters) (h += ',') += p.name;
  for (const auto& r : response_names(c)) (h += ',') += r;
  return h + ",o1,o2,wall_s";
}

std::string evaluation_row(const Evaluation& e) {
  std::string s = std::to_string(e.generation);
  (s += ',') += std::to_string(e.index);
  for (double v : e.x) (s += ',') += g17(v);
  for (double v : e.responses) (s += ',') += g17(v);
  for (double v : {e.o1, e.o2, e.wall_s}) (s += ',') += g17(v);
  return s;
}

std::vector<Evaluation> read_evaluations(const std::string& path, std::size_t n_param, std::size_t n_resp) {
  std::vector<Evaluation> out;
  std::ifstream in(path);
  std::string line;
  std::getline(in, line);  // header
  while (std::getline(in, line)) {
    std::vector<std::string> f;
    std::stringstream ss(line);
    std::string c;
    while (std::getline(ss, c, ',')) f.push_back(c);
    if (f.size() != 2 + n_param + n_resp + 3) continue;
    try {
      Evaluation e;
      e.generation = std::stoull(f[0]);
      e.index = std::stoull(f[1]);
      for (std::size_t k = 0; k < n_param; ++k) e.x.push_back(std::stod(f[2 + k]));
      for (std::size_t k = 0; k < n_resp; ++k) e.responses.push_back(std::stod(f[2 + n_param + k]));
      e.o1 = std::stod(f[2 + n_param + n_resp]);
      e.o2 = std::stod(f[3 + n_param + n_resp]);
      e.wall_s = std::stod(f[4 + n_param + n_resp]);
      out.push_back(e);
    } catch (const std::exception&) {
    }
  }
  return out;
}

}  // namespace biodem::calib
