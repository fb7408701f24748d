// The case as understood, for people: the resolved values and the derived quantities
// (case_file/derived_quantities.hpp) as readable text, printed by `biodem check` and written at
// the top of run.log (SPEC 11).
#pragma once
#include <string>

#include "config/case_config.hpp"

namespace biodem::output {

/// The resolved case and its derived quantities as readable multi-line text.
std::string describe_case(const config::CaseConfig& c);

}  // namespace biodem::output
