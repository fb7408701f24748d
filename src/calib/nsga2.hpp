// NSGA-II glue (SPEC 7, issue 9): pagmo's NSGA-II drives the search, every population
// is handed to a batch evaluator at once (so that the caller can run it in parallel), and every
// evaluation is cached by its exact decision vector. The cache is what makes a campaign
// resumable: a restarted campaign with the same seed asks for the same vectors in the same
// order, and the ones already evaluated are answered from the cache. The result depends only on
// the problem, the bounds, the seed and the evaluator, never on how the batch is evaluated.
#pragma once
#include <cstdint>
#include <functional>
#include <map>
#include <vector>

#include "calib/evaluation.hpp"

namespace biodem::calib {

struct CampaignSettings {
  std::vector<double> lower, upper;  // bounds of each parameter
  std::uint64_t population = 8;      // NSGA-II: > 4 and a multiple of 4
  std::uint64_t generations = 2;
  std::uint64_t seed = 1;
  double crossover_probability = 0.95, crossover_distribution = 10.0;
  double mutation_probability = -1.0;  // < 0: 1 / number of parameters
  double mutation_distribution = 50.0;
};

/// Evaluates a batch of decision vectors (fills responses, o1, o2, wall_s of each; generation,
/// index and x are set by the caller).
using BatchEvaluator = std::function<void(std::vector<Evaluation>&)>;
/// Called after each batch with all evaluations of that batch (for logs, files, progress).
using BatchListener = std::function<void(const std::vector<Evaluation>&)>;

struct CampaignResult {
  std::vector<Evaluation> evaluations;  // in order (generation, index)
  std::vector<Evaluation> pareto;       // final non-dominated set, distinct vectors, sorted by o1
};

/// Runs NSGA-II. `cache` (exact decision vector -> earlier evaluation) answers repeated vectors
/// without calling the evaluator; new evaluations are added to it.
CampaignResult run_nsga2(const CampaignSettings& s, const BatchEvaluator& evaluate, const BatchListener& listener,
                         std::map<std::vector<double>, Evaluation>& cache);

/// Non-dominated subset (both objectives minimised), distinct decision vectors, sorted by o1.
std::vector<Evaluation> pareto_front(const std::vector<Evaluation>& all);

/// Hypervolume (2 objectives, minimised) of a set of points against a reference point.
double hypervolume_2d(std::vector<std::pair<double, double>> points, double ref_o1, double ref_o2);

}  // namespace biodem::calib
