#include "calib/evaluations_csv.hpp"

#include <charconv>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>

#include "calib/objectives.hpp"
#include "core/error.hpp"

namespace biodem::calib {
namespace {

// The shortest text that reads back as the same double (0.4, not 0.40000000000000002): exact
// for --resume and the cache, and what a person expects to read.
std::string shortest(double v) {
  char b[64];
  const auto r = std::to_chars(b, b + sizeof b, v);
  return std::string(b, r.ptr);
}

// The cells of a line of a CSV file written by hand or by a spreadsheet: spaces and a carriage
// return trimmed, surrounding double quotes removed (no commas inside quotes).
std::vector<std::string> fields(const std::string& line) {
  std::vector<std::string> f;
  std::stringstream ss(line);
  std::string c;
  auto trim = [](std::string& x) {
    while (!x.empty() && (x.back() == '\r' || x.back() == ' ' || x.back() == '\t')) x.pop_back();
    while (!x.empty() && (x.front() == ' ' || x.front() == '\t')) x.erase(x.begin());
    if (x.size() >= 2 && x.front() == '"' && x.back() == '"') x = x.substr(1, x.size() - 2);
  };
  while (std::getline(ss, c, ',')) {
    trim(c);
    f.push_back(c);
  }
  if (!line.empty() && line.back() == ',') f.emplace_back();
  return f;
}

bool blank_or_comment(const std::string& line) {
  const auto k = line.find_first_not_of(" \t\r");
  return k == std::string::npos || line[k] == '#';
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
  for (double v : e.x) (s += ',') += shortest(v);
  for (double v : e.responses) (s += ',') += shortest(v);
  for (double v : {e.o1, e.o2, e.wall_s}) (s += ',') += shortest(v);
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

std::vector<std::vector<double>> read_parameter_rows(const std::string& path, const CalibConfig& c) {
  std::ifstream in(path);
  if (!in) throw Error("--evaluate " + path + ": cannot read");
  std::string line;
  std::size_t n = 1;
  while (std::getline(in, line) && blank_or_comment(line)) ++n;
  if (!in) throw Error("--evaluate " + path + ": empty file (a header row naming the parameters is needed)");
  if (line.rfind("\xEF\xBB\xBF", 0) == 0) line.erase(0, 3);  // a UTF-8 byte order mark
  const auto header = fields(line);
  std::vector<std::size_t> column;
  for (const auto& p : c.parameters) {
    std::size_t k = 0;
    while (k < header.size() && header[k] != p.name) ++k;
    if (k == header.size()) {
      std::string found;
      for (const auto& h : header) found += (found.empty() ? "" : ",") + h;
      throw Error("--evaluate " + path + ": no column \"" + p.name + "\" (a parameter of " + c.source_path +
                  ") in the header \"" + found + "\" (line " + std::to_string(n) + ")");
    }
    column.push_back(k);
  }
  std::vector<std::vector<double>> rows;
  while (std::getline(in, line)) {
    ++n;
    if (blank_or_comment(line)) continue;
    const auto f = fields(line);
    std::vector<double> x;
    for (std::size_t k = 0; k < column.size(); ++k) {
      const auto& p = c.parameters[k];
      const std::string where = "--evaluate " + path + " line " + std::to_string(n) + ", column " + p.name;
      if (column[k] >= f.size()) throw Error(where + ": missing");
      double v = NAN;
      std::size_t used = 0;
      try {
        v = std::stod(f[column[k]], &used);
      } catch (const std::exception&) {
        used = 0;
      }
      if (used == 0 || used != f[column[k]].size() || !std::isfinite(v))
        throw Error(where + ": \"" + f[column[k]] + "\" is not a number");
      if (v < p.lower || v > p.upper)
        throw Error(where + " = " + shortest(v) + ": outside the parameter's bounds [" + shortest(p.lower) + ", " + shortest(p.upper) + "]");
      x.push_back(v);
    }
    rows.push_back(std::move(x));
  }
  if (rows.empty()) throw Error("--evaluate " + path + ": no rows to evaluate");
  return rows;
}

}  // namespace biodem::calib
