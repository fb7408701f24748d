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

/// The decision vectors of `calibrate --evaluate FILE`: a CSV file with a header row that names
/// every parameter of `c` (other columns, such as a pareto.csv's responses and objectives, are
/// ignored), one vector per row, in row order. Throws biodem::Error naming the file, the line and
/// the column on a missing column, a cell that is not a number or a value outside the
/// parameter's bounds, and on a file without rows.
std::vector<std::vector<double>> read_parameter_rows(const std::string& path, const CalibConfig& c);

}  // namespace biodem::calib
