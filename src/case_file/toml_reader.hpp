// Typed, checked access to the keys of one TOML table (toml++), shared by the parsers of the
// case file's tables: every message names the file, the table path and the key, and quotes the
// value as written. Internal to src/case_file.
#pragma once
#include <toml++/toml.h>

#include <algorithm>
#include <cstddef>
#include <initializer_list>
#include <limits>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "config/case_config.hpp"
#include "core/error.hpp"

namespace biodem::case_file::detail {

constexpr double kInf = std::numeric_limits<double>::infinity();

std::string num(double v, int digits = 6);
std::size_t edit_distance(std::string_view a, std::string_view b);
/// " (did you mean X?)" for the closest candidate within a few edits, else "".
std::string suggestion(std::string_view key, const std::vector<std::string_view>& candidates,
                       std::string_view prefix = "", std::string_view suffix = "");
std::string join(const std::vector<std::string_view>& v);
/// A value as the user wrote it, for messages.
std::string show(const toml::node& n);
/// "a string", "an integer" ...: the TOML type of a value, for messages.
std::string type_name(const toml::node& n);

/// Allowed interval of a real value, with its wording for messages.
struct Range {
  double lo = -kInf, hi = kInf;
  bool lo_incl = true, hi_incl = true;
  bool contains(double v) const {
    return (lo_incl ? v >= lo : v > lo) && (hi_incl ? v <= hi : v < hi);
  }
  std::string text() const {
    if (hi == kInf) return std::string("must be ") + (lo_incl ? ">= " : "> ") + num(lo);
    if (lo == -kInf) return std::string("must be ") + (hi_incl ? "<= " : "< ") + num(hi);
    return "must be in " + std::string(lo_incl ? "[" : "(") + num(lo) + ", " + num(hi) + (hi_incl ? "]" : ")");
  }
};
constexpr Range kAny{};
constexpr Range kPositive{0.0, kInf, false, true};
constexpr Range kNonNegative{0.0, kInf, true, true};
constexpr Range kUnitOpenClosed{0.0, 1.0, false, true};  // (0, 1]
constexpr Range kUnitOpen{0.0, 1.0, false, false};       // (0, 1)

/// Reads the keys of one table with typed accessors; every message names the file, the table
/// path and the key. Unknown keys are rejected on construction.
class Reader {
 public:
  Reader(const std::string& file, const toml::table& t, std::string path, bool array_entry,
         std::initializer_list<std::string_view> allowed)
      : file_(file), t_(t), path_(std::move(path)), array_entry_(array_entry), allowed_(allowed) {
    for (auto&& [k, v] : t_) {
      const std::string_view key = k.str();
      if (std::find(allowed_.begin(), allowed_.end(), key) == allowed_.end())
        throw Error(file_ + ": unknown key " + where(key) + suggestion(key, allowed_) + "; allowed keys: " +
                    join(allowed_));
    }
  }

  Reader(const std::string& file, const toml::table& t, std::string path, bool array_entry,
         const std::vector<std::string_view>& allowed)
      : file_(file), t_(t), path_(std::move(path)), array_entry_(array_entry), allowed_(allowed) {
    for (auto&& [k, v] : t_) {
      const std::string_view key = k.str();
      if (std::find(allowed_.begin(), allowed_.end(), key) == allowed_.end())
        throw Error(file_ + ": unknown key " + where(key) + suggestion(key, allowed_) + "; allowed keys: " +
                    join(allowed_));
    }
  }

  const std::string& path() const { return path_; }
  std::string where(std::string_view key) const { return path_ + (array_entry_ ? " ." : ".") + std::string(key); }
  bool has(std::string_view key) const { return t_.contains(key); }
  const toml::node* node(std::string_view key) const { return t_.get(key); }

  /// "<file>: <path>.<key> = <value>: <reason>" (without "= value" if the key is absent).
  [[noreturn]] void fail(std::string_view key, const std::string& reason) const {
    const toml::node* n = t_.get(key);
    throw Error(file_ + ": " + where(key) + (n ? " = " + show(*n) : std::string()) + ": " + reason);
  }
  [[noreturn]] void missing(std::string_view key, const std::string& what = "") const {
    throw Error(file_ + ": " + where(key) + ": required key is missing" + what);
  }

  // --- reals (TOML integers are accepted and converted) ---
  std::optional<double> opt_real(std::string_view key, Range r = kAny) const {
    const toml::node* n = t_.get(key);
    if (!n) return std::nullopt;
    double v;
    if (auto f = n->as_floating_point())
      v = f->get();
    else if (auto i = n->as_integer())
      v = static_cast<double>(i->get());
    else
      fail(key, "must be a number, not " + type_name(*n));
    if (!std::isfinite(v)) fail(key, "must be a finite number");
    if (!r.contains(v)) fail(key, r.text());
    return v;
  }
  double real(std::string_view key, Range r = kAny) const {
    if (!has(key)) missing(key);
    return *opt_real(key, r);
  }
  double real_or(std::string_view key, double def, Range r = kAny) const { return opt_real(key, r).value_or(def); }

  // --- integers (reals are rejected, even 350.0) ---
  std::optional<std::uint64_t> opt_uint(std::string_view key, std::uint64_t min,
                                        std::uint64_t max = std::numeric_limits<std::uint64_t>::max()) const {
    const toml::node* n = t_.get(key);
    if (!n) return std::nullopt;
    const std::string need = min == 0   ? "must be a non-negative integer"
                             : min == 1 ? "must be a positive integer"
                                        : "must be an integer >= " + std::to_string(min);
    if (n->is_floating_point()) fail(key, "must be an integer, written without a decimal point or exponent");
    auto i = n->as_integer();
    if (!i) fail(key, "must be an integer, not " + type_name(*n));
    if (i->get() < 0 || static_cast<std::uint64_t>(i->get()) < min) fail(key, need);
    if (static_cast<std::uint64_t>(i->get()) > max) fail(key, "must be <= " + std::to_string(max));
    return static_cast<std::uint64_t>(i->get());
  }

  std::optional<bool> opt_bool(std::string_view key) const {
    const toml::node* n = t_.get(key);
    if (!n) return std::nullopt;
    auto b = n->as_boolean();
    if (!b) fail(key, "must be true or false, not " + type_name(*n));
    return b->get();
  }

  std::optional<std::string> opt_string(std::string_view key) const {
    const toml::node* n = t_.get(key);
    if (!n) return std::nullopt;
    auto s = n->as_string();
    if (!s) fail(key, "must be a string, not " + type_name(*n));
    return s->get();
  }
  std::string string(std::string_view key) const {
    if (!has(key)) missing(key);
    return *opt_string(key);
  }

  /// Array of exactly `count` finite numbers (integers accepted).
  std::optional<std::vector<double>> opt_numbers(std::string_view key, std::size_t count,
                                                 const std::string& form) const {
    const toml::node* n = t_.get(key);
    if (!n) return std::nullopt;
    auto a = n->as_array();
    const std::string need = "must be an array of " + std::to_string(count) + " numbers " + form;
    if (!a || a->size() != count) fail(key, need);
    std::vector<double> out;
    for (const auto& e : *a) {
      if (auto f = e.as_floating_point())
        out.push_back(f->get());
      else if (auto i = e.as_integer())
        out.push_back(static_cast<double>(i->get()));
      else
        fail(key, need);
      if (!std::isfinite(out.back())) fail(key, "must contain finite numbers");
    }
    return out;
  }
  std::optional<config::Vec3d> opt_vec3(std::string_view key) const {
    auto v = opt_numbers(key, 3, "[x, y, z]");
    if (!v) return std::nullopt;
    return config::Vec3d{(*v)[0], (*v)[1], (*v)[2]};
  }
  config::Vec3d vec3(std::string_view key) const {
    if (!has(key)) missing(key);
    return *opt_vec3(key);
  }
  /// A direction, normalised; zero length is an error.
  config::Vec3d unit_vec3(std::string_view key) const {
    const config::Vec3d v = vec3(key);
    const double n = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    if (!(n > 0.0)) fail(key, "must be a non-zero direction");
    return {v[0] / n, v[1] / n, v[2] / n};
  }

 private:
  const std::string& file_;
  const toml::table& t_;
  std::string path_;
  bool array_entry_;
  std::vector<std::string_view> allowed_;
};

}  // namespace biodem::case_file::detail
