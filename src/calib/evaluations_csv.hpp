// evaluations.csv, pareto.csv and cache.csv (SPEC 11, docs/outputs.md): one row per evaluation,
// `generation, index`, one column per parameter, one per response (response_names), `o1, o2,
// wall_s`; numbers with 17 significant digits, so that a row read back is the same evaluation
// bit for bit (the cache that makes --resume exact).
#pragma once
#include <string>
#include <vector>

#include "calib/calib_file.hpp"
#include "calib/evaluation.hpp"

namespace biodem::calib {

std::string evaluations_header(const CalibConfig& c);
std::string evaluation_row(const Evaluation& e);

/// Rows of a file written with evaluations_header / evaluation_row; malformed or incomplete lines
/// (a kill mid-write) are skipped. A missing file reads as no rows.
std::vector<Evaluation> read_evaluations(const std::string& path, std::size_t n_param, std::size_t n_resp);

}  // namespace biodem::calib
