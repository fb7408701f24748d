#include "calib/campaign_plots.hpp"

#include <cmath>

#include "calib/objectives.hpp"
#include "output/plot_writer.hpp"

namespace biodem::calib {

void write_campaign_plots(const CalibConfig& c, const CampaignResult& r, const std::string& out_dir) {
  output::Plot pf;
  pf.title = "Pareto front";
  pf.x_label = "o1 (relative error)";
  pf.y_label = "o2 (relative error)";
  output::PlotSeries all{"all evaluations", {}, {}, output::PlotStyle::markers};
  output::PlotSeries front{"Pareto set", {}, {}, output::PlotStyle::markers};
  front.marker = output::Marker::triangle_up;
  front.marker_size = 6.0;
  for (const auto& e : r.evaluations)
    if (e.o1 < 1e9) {  // failed evaluations are scored 1e9
      all.x.push_back(e.o1);
      all.y.push_back(e.o2);
    }
  for (const auto& e : r.pareto) {
    front.x.push_back(e.o1);
    front.y.push_back(e.o2);
  }
  pf.series = {all, front};
  output::write_plot(pf, out_dir + "/pareto");
  const auto names = response_names(c);
  for (std::size_t i = 0; i < names.size(); ++i)
    for (std::size_t k = 0; k < c.parameters.size(); ++k) {
      output::Plot p;
      p.title = names[i] + " vs " + c.parameters[k].name;
      p.x_label = c.parameters[k].name;
      p.y_label = names[i];
      output::PlotSeries s{"evaluations", {}, {}, output::PlotStyle::markers};
      for (const auto& e : r.evaluations)
        if (std::isfinite(e.responses[i])) {
          s.x.push_back(e.x[k]);
          s.y.push_back(e.responses[i]);
        }
      output::PlotSeries t{"target", {c.parameters[k].lower, c.parameters[k].upper},
                           {target_of(c, names[i]).value, target_of(c, names[i]).value}};
      p.series = {s, t};
      output::write_plot(p, out_dir + "/" + names[i] + "_vs_" + c.parameters[k].name);
    }
}

}  // namespace biodem::calib
