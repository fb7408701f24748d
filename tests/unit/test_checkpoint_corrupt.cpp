// Checkpoints that pass the checksum but do not fit together (issue 10, item 8; found while
// writing the checkpoint fuzzer, tests/fuzz/). Before the fix, such a file was accepted and the next step
// indexed out of bounds, and a string length near 2^64 wrapped the bounds check. Each must now
// be a one-line biodem::Error naming the file and the part that is wrong.
#include <gtest/gtest.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <string>
#include <vector>

#include <unistd.h>

#include "core/error.hpp"
#include "fuzz/fuzz_scene.hpp"
#include "io/checkpoint.hpp"

using namespace biodem;

namespace {

std::vector<char> read_all(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>()};
}

/// A checkpoint of the fuzz scene after 50 steps, modified by `edit` before saving.
std::vector<char> checkpoint_of(const std::function<void(sim::Simulation&)>& edit) {
  sim::Simulation s = fuzz::make_scene();
  s.run_steps(50);
  edit(s);
  io::RunProgress rp;
  rp.pvd_spheres = {{0.0, "spheres_0.vtu"}};
  // One file per process: ctest runs the tests of this file as parallel processes, and a shared
  // name let one test remove the file another was reading (a CI failure).
  const std::string path = (std::filesystem::temp_directory_path() /
                            ("biodem_corrupt_test_" + std::to_string(static_cast<long>(::getpid())) + ".ckpt"))
                               .string();
  io::save_checkpoint(path, s, rp);
  auto bytes = read_all(path);
  std::filesystem::remove(path);
  return bytes;
}

/// Loads `bytes` into a fresh scene; returns the error message ("" when it loaded).
std::string load_error(const std::vector<char>& bytes) {
  sim::Simulation s = fuzz::make_scene();
  try {
    io::load_checkpoint_bytes(bytes, "run/checkpoint.bin", s);
    s.step();
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

void expect_one_line_error(const std::string& msg, const std::string& part) {
  EXPECT_NE(msg.find("run/checkpoint.bin: "), std::string::npos) << msg;
  EXPECT_NE(msg.find(part), std::string::npos) << msg;
  EXPECT_EQ(msg.find('\n'), std::string::npos) << msg;
}

}  // namespace

TEST(CheckpointCorrupt, ValidCheckpointLoadsAndSteps) {
  EXPECT_EQ(load_error(checkpoint_of([](sim::Simulation&) {})), "");
}

TEST(CheckpointCorrupt, HugeStringLengthIsTruncationNotACrash) {
  std::vector<char> b = checkpoint_of([](sim::Simulation&) {});
  // Payload layout: 8 fields of 8 bytes, the pvd count (1), its time, then the string length.
  const std::size_t head = 8 + 4 + 8, at = head + 8 * 8 + 8 + 8;
  const std::uint64_t huge = ~0ull - 8;
  std::memcpy(b.data() + at, &huge, 8);
  const std::uint64_t sum = io::fnv1a(b.data() + head, b.size() - head - 8);
  std::memcpy(b.data() + b.size() - 8, &sum, 8);
  expect_one_line_error(load_error(b), "truncated checkpoint");
}

TEST(CheckpointCorrupt, IndicesThatDoNotFitAreRejected) {
  expect_one_line_error(load_error(checkpoint_of([](sim::Simulation& s) { s.bodies_mut().shape[0] = 7; })),
                        "body shape index");
  expect_one_line_error(load_error(checkpoint_of([](sim::Simulation& s) { s.spheres_mut().body[1] = 99; })),
                        "sphere body index");
  expect_one_line_error(load_error(checkpoint_of([](sim::Simulation& s) { s.spheres_mut().material[0] = 5; })),
                        "sphere material index");
  expect_one_line_error(load_error(checkpoint_of([](sim::Simulation& s) { s.bodies_mut().first_sphere[1] += 1; })),
                        "body sphere ranges");
  expect_one_line_error(load_error(checkpoint_of([](sim::Simulation& s) { s.bodies_mut().mass_kg.pop_back(); })),
                        "body arrays of different lengths");
  expect_one_line_error(load_error(checkpoint_of([](sim::Simulation& s) { s.wall_contacts().wall.assign(s.wall_contacts().wall.size(), 9); })),
                        "wall contact table");
  expect_one_line_error(load_error(checkpoint_of([](sim::Simulation& s) {
                          auto& l = s.neighbor_list_mut();
                          ASSERT_GT(l.j.size(), 0u);
                          l.j[0] = 1000;
                        })),
                        "neighbour list entries");
  expect_one_line_error(load_error(checkpoint_of([](sim::Simulation& s) { s.bodies_mut().position_m[2].y = NAN; })),
                        "non-finite body state");
  // Found by the fuzzer: rows that are not monotone (an entry beyond the table), a negative skin.
  expect_one_line_error(load_error(checkpoint_of([](sim::Simulation& s) {
                          s.neighbor_list_mut().row_start[1] = static_cast<std::uint32_t>(s.neighbor_list().j.size() + 5);
                        })),
                        "neighbour list rows");
  expect_one_line_error(load_error(checkpoint_of([](sim::Simulation& s) { s.set_skin(-0.5e-3); })), "time or skin");
}
