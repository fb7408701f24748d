// The lean build without OpenCV (docs/gpu.md): `biodem video` says in one line that it is not
// built, and exits non-zero.
#include "../commands.hpp"
#include "core/error.hpp"

namespace biodem::cli {

Action register_video(CLI::App& app) {
  auto* sub = app.add_subcommand("video", "Video analysis (not built: this is a lean build without OpenCV)");
  sub->allow_extras();
  return []() -> int {
    throw Error("video: not built (this biodem is a lean build without OpenCV; see docs/gpu.md)");
  };
}

}  // namespace biodem::cli
