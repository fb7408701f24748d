#include "calib/nsga2.hpp"

#include <algorithm>
#include <memory>
#include <stdexcept>

#include <pagmo/algorithms/nsga2.hpp>
#include <pagmo/batch_evaluators/default_bfe.hpp>
#include <pagmo/bfe.hpp>
#include <pagmo/population.hpp>
#include <pagmo/problem.hpp>

namespace biodem::calib {
namespace {

// Shared state between the problem, the batch evaluator (pagmo copies both) and run_nsga2.
struct State {
  const CampaignSettings* settings = nullptr;
  const BatchEvaluator* evaluate = nullptr;
  const BatchListener* listener = nullptr;
  std::map<std::vector<double>, Evaluation>* cache = nullptr;
  std::vector<Evaluation> log;
  std::uint64_t batches = 0;

  // One batch: cached vectors are answered at once, the others are evaluated together.
  std::vector<Evaluation> run_batch(const std::vector<std::vector<double>>& xs) {
    std::vector<Evaluation> batch(xs.size());
    std::vector<Evaluation> todo;
    std::vector<std::size_t> where;
    for (std::size_t k = 0; k < xs.size(); ++k) {
      auto it = cache->find(xs[k]);
      if (it != cache->end()) {
        batch[k] = it->second;
      } else {
        Evaluation e;
        e.x = xs[k];
        todo.push_back(e);
        where.push_back(k);
      }
      batch[k].generation = batches;
      batch[k].index = k;
      batch[k].x = xs[k];
    }
    if (!todo.empty()) {
      for (std::size_t q = 0; q < todo.size(); ++q) {
        todo[q].generation = batches;
        todo[q].index = where[q];
      }
      (*evaluate)(todo);
      for (std::size_t q = 0; q < todo.size(); ++q) {
        batch[where[q]] = todo[q];
        (*cache)[todo[q].x] = todo[q];
      }
    }
    for (auto& e : batch) log.push_back(e);
    if (*listener) (*listener)(batch);
    ++batches;
    return batch;
  }
};

State* g_state = nullptr;  // pagmo problems and bfes must be copyable: they reach the state here

struct Problem {
  std::vector<double> lower, upper;
  pagmo::vector_double fitness(const pagmo::vector_double& x) const {
    const auto b = g_state->run_batch({x});
    return {b[0].o1, b[0].o2};
  }
  std::pair<pagmo::vector_double, pagmo::vector_double> get_bounds() const { return {lower, upper}; }
  pagmo::vector_double::size_type get_nobj() const { return 2; }
};

struct BatchFitness {
  pagmo::vector_double operator()(const pagmo::problem& p, const pagmo::vector_double& dvs) const {
    const std::size_t n = p.get_nx(), m = dvs.size() / n;
    std::vector<std::vector<double>> xs(m);
    for (std::size_t k = 0; k < m; ++k) xs[k].assign(dvs.begin() + k * n, dvs.begin() + (k + 1) * n);
    const auto b = g_state->run_batch(xs);
    pagmo::vector_double f(2 * m);
    for (std::size_t k = 0; k < m; ++k) {
      f[2 * k] = b[k].o1;
      f[2 * k + 1] = b[k].o2;
    }
    return f;
  }
};

}  // namespace

std::vector<Evaluation> pareto_front(const std::vector<Evaluation>& all) {
  std::map<std::vector<double>, Evaluation> distinct;
  for (const auto& e : all) distinct.emplace(e.x, e);
  std::vector<Evaluation> out;
  for (const auto& [x, e] : distinct) {
    bool dominated = false;
    for (const auto& [y, f] : distinct)
      if (f.o1 <= e.o1 && f.o2 <= e.o2 && (f.o1 < e.o1 || f.o2 < e.o2)) {
        dominated = true;
        break;
      }
    if (!dominated) out.push_back(e);
  }
  std::sort(out.begin(), out.end(), [](const Evaluation& a, const Evaluation& b) {
    return a.o1 != b.o1 ? a.o1 < b.o1 : (a.o2 != b.o2 ? a.o2 < b.o2 : a.x < b.x);
  });
  return out;
}

double hypervolume_2d(std::vector<std::pair<double, double>> p, double r1, double r2) {
  std::sort(p.begin(), p.end());
  // Staircase of the non-dominated points (sorted by o1, strictly decreasing o2).
  double hv = 0.0;
  double prev_o2 = r2;
  std::vector<std::pair<double, double>> stair;
  for (const auto& [a, b] : p)
    if (a < r1 && b < prev_o2) {
      stair.emplace_back(a, b);
      prev_o2 = b;
    }
  for (std::size_t k = 0; k < stair.size(); ++k) {
    const double next_o1 = k + 1 < stair.size() ? stair[k + 1].first : r1;
    hv += (next_o1 - stair[k].first) * (r2 - stair[k].second);
  }
  return hv;
}

CampaignResult run_nsga2(const CampaignSettings& s, const BatchEvaluator& evaluate, const BatchListener& listener,
                         std::map<std::vector<double>, Evaluation>& cache) {
  if (s.population < 5 || s.population % 4 != 0)
    throw std::invalid_argument("NSGA-II needs a population of more than 4 and a multiple of 4");
  State st;
  st.settings = &s;
  st.evaluate = &evaluate;
  st.listener = &listener;
  st.cache = &cache;
  g_state = &st;
  struct Reset {
    ~Reset() { g_state = nullptr; }
  } reset;
  Problem prob{s.lower, s.upper};
  pagmo::problem p{prob};
  pagmo::bfe b{BatchFitness{}};
  pagmo::population pop{p, b, static_cast<pagmo::population::size_type>(s.population),
                        static_cast<unsigned>(s.seed)};
  const double m = s.mutation_probability < 0.0 ? 1.0 / static_cast<double>(s.lower.size()) : s.mutation_probability;
  pagmo::nsga2 algo(static_cast<unsigned>(s.generations), s.crossover_probability, s.crossover_distribution, m,
                    s.mutation_distribution, static_cast<unsigned>(s.seed));
  algo.set_bfe(b);
  pop = algo.evolve(pop);
  CampaignResult r;
  r.evaluations = st.log;
  // The final non-dominated set of the final population.
  std::vector<Evaluation> last;
  for (const auto& x : pop.get_x()) last.push_back(cache.at(x));
  r.pareto = pareto_front(last);
  return r;
}

}  // namespace biodem::calib
