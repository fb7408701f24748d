// The lean build without OpenCV (docs/gpu.md): no plots. analyze and compare check
// output::plots_built() and skip them; anything else that asks for a plot gets one clear line.
#include "core/error.hpp"
#include "output/plot_writer.hpp"

namespace biodem::output {

void write_plot(const Plot&, const std::filesystem::path& stem) {
  throw Error(stem.string() + ": plots are not built in this lean build (no OpenCV)");
}

}  // namespace biodem::output
