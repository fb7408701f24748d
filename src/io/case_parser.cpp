#include "io/case_parser.hpp"

#include "core/error.hpp"

namespace biodem::io {

LoadedCase load_case(const std::string& path) { throw Error(path + ": case parser not implemented yet"); }
LoadedCase parse_case(std::string_view, const std::string& source_name) {
  throw Error(source_name + ": case parser not implemented yet");
}

}  // namespace biodem::io
