// Checkpoints that pass the checksum but do not fit together (issue 10, item 8; found while
// writing the checkpoint fuzzer, tests/fuzz/). Before the fix, such a file was accepted and the next step
// indexed out of bounds, and a string length near 2^64 wrapped the bounds check. Each must now
// be a one-line biodem::Error naming the file and the part that is wrong.
#include <gtest/gtest.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <random>
#include <sstream>
#include <iterator>
#include <string>
#include <vector>
#include <utility>

#include <unistd.h>

#include "core/error.hpp"
#include "fuzz/fuzz_scene.hpp"
#include "checkpoint/checkpoint.hpp"

using namespace biodem;

namespace {

std::vector<char> read_all(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>()};
}

/// A checkpoint of the fuzz scene after 50 steps, modified by `edit` before saving.
std::vector<char> checkpoint_of(const std::function<void(sim::Simulation&)>& edit,
                                const std::function<void(checkpoint::RunProgress&)>& edit_progress = {}) {
  sim::Simulation s = fuzz::make_scene();
  s.run_steps(50);
  edit(s);
  checkpoint::RunProgress rp;
  rp.pvd_spheres = {{0.0, "spheres_0.vtu"}};
  if (edit_progress) edit_progress(rp);
  // One file per process: ctest runs the tests of this file as parallel processes, and a shared
  // name let one test remove the file another was reading (a CI failure).
  const std::string path = (std::filesystem::temp_directory_path() /
                            ("biodem_corrupt_test_" + std::to_string(static_cast<long>(::getpid())) + ".ckpt"))
                               .string();
  checkpoint::save_checkpoint(path, s, rp);
  auto bytes = read_all(path);
  std::filesystem::remove(path);
  return bytes;
}

/// Header: magic (8), version (4), payload size (8); the checksum (8) ends the file.
constexpr std::size_t kHead = 8 + 4 + 8;

/// Sets the version, cuts the payload to `payload_size` bytes and writes a matching checksum.
void rewrap(std::vector<char>& b, std::uint32_t version, std::size_t payload_size) {
  b.resize(kHead + payload_size + 8);
  std::memcpy(b.data() + 8, &version, 4);
  const std::uint64_t size = payload_size;
  std::memcpy(b.data() + 12, &size, 8);
  const std::uint64_t sum = checkpoint::fnv1a(b.data() + kHead, payload_size);
  std::memcpy(b.data() + kHead + payload_size, &sum, 8);
}

/// Loads `bytes` into a fresh scene; returns the error message ("" when it loaded).
std::string load_error(const std::vector<char>& bytes) {
  sim::Simulation s = fuzz::make_scene();
  try {
    checkpoint::load_checkpoint_bytes(bytes, "run/checkpoint.bin", s);
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
  const std::uint64_t sum = checkpoint::fnv1a(b.data() + head, b.size() - head - 8);
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

// Version 5 (issue 10, item 5) appends the contact count, the last sample and snapshot steps, the
// last settle verdict and the insertion state (flag, four counters, the generator's text);
// version 6 the engine that wrote the file and its GPU contact-sum family (two strings).
// Versions 4 and 5 are the same payload without those tails: they are still read (version 4 with
// no insertion under way, both with no engine recorded); version 3 and older, and versions
// newer than this biodem's, are refused in one line.
TEST(CheckpointVersions, Versions4And5AreReadAndOthersAreRefused) {
  std::vector<char> b = checkpoint_of([](sim::Simulation&) {}, [](checkpoint::RunProgress& rp) {
    rp.last_sample_step = 40;
    rp.last_snapshot_step = 30;
    rp.last_settled = true;
    rp.engine = "gpu-emulated";
    rp.contact_sums = "fixed";
  });
  const std::size_t tail6 = 8 + 12 + 8 + 5;  // two strings: length and bytes
  const std::size_t tail5 = 8 + 8 + 8 + 1 + 1 + 4 * 8 + 8;  // no generator text: insertion inactive
  const std::size_t payload = b.size() - kHead - 8;
  {
    sim::Simulation s = fuzz::make_scene();
    const auto rp = checkpoint::load_checkpoint_bytes(b, "run/checkpoint.bin", s);
    EXPECT_EQ(rp.version, 6u);
    EXPECT_EQ(rp.last_sample_step, 40u);
    EXPECT_EQ(rp.last_snapshot_step, 30u);
    EXPECT_TRUE(rp.last_settled);
    EXPECT_FALSE(rp.insertion.active);
    EXPECT_EQ(rp.engine, "gpu-emulated");
    EXPECT_EQ(rp.contact_sums, "fixed");
  }
  std::vector<char> v5 = b;
  rewrap(v5, 5, payload - tail6);
  {
    sim::Simulation s = fuzz::make_scene();
    const auto rp = checkpoint::load_checkpoint_bytes(v5, "run/checkpoint.bin", s);
    EXPECT_EQ(rp.version, 5u);
    EXPECT_EQ(rp.last_sample_step, 40u);
    EXPECT_TRUE(rp.last_settled);
    EXPECT_EQ(rp.engine, "");
    EXPECT_EQ(rp.contact_sums, "");
    s.step();
  }
  std::vector<char> v4 = b;
  rewrap(v4, 4, payload - tail6 - tail5);
  {
    sim::Simulation s = fuzz::make_scene();
    const auto rp = checkpoint::load_checkpoint_bytes(v4, "run/checkpoint.bin", s);
    EXPECT_EQ(rp.version, 4u);
    EXPECT_EQ(rp.last_sample_step, checkpoint::RunProgress::kNever);
    EXPECT_FALSE(rp.last_settled);
    EXPECT_FALSE(rp.insertion.active);
    EXPECT_EQ(s.step_count(), 50u);
    s.step();
  }
  // A version-6 payload read as version 5 has trailing bytes: refused.
  std::vector<char> v6as5 = b;
  rewrap(v6as5, 5, payload);
  expect_one_line_error(load_error(v6as5), "trailing data");
  std::vector<char> v3 = v4;
  rewrap(v3, 3, payload - tail6 - tail5);
  expect_one_line_error(load_error(v3), "checkpoint format version 3, this biodem reads versions 4 to 6");
  // The engine and the family are checked when read: one of the names a run writes.
  for (const auto& [engine, sums] : std::vector<std::pair<std::string, std::string>>{
           {"gpu\nx", "fixed"}, {"cpu", "fixed"}, {"gpu", ""}, {"gpu", "sorted"}, {"", "ordered"}}) {
    const std::vector<char> bad = checkpoint_of([](sim::Simulation&) {}, [&](checkpoint::RunProgress& rp) {
      rp.engine = engine;
      rp.contact_sums = sums;
    });
    expect_one_line_error(load_error(bad), "corrupt checkpoint (engine or GPU contact sums)");
  }
  std::vector<char> v7 = b;
  rewrap(v7, 7, payload);
  expect_one_line_error(load_error(v7), "checkpoint format version 7");
}

// The insertion state round-trips, its generator included (the next draws are the same), and a
// damaged generator text is a one-line error.
TEST(CheckpointVersions, InsertionStateRoundTripsAndADamagedGeneratorIsRejected) {
  std::mt19937_64 g(12345);
  for (int k = 0; k < 1000; ++k) g();
  std::ostringstream text;  // the generator's state as the checkpoint writes it
  text << g;
  std::vector<char> b = checkpoint_of([](sim::Simulation&) {}, [&](checkpoint::RunProgress& rp) {
    rp.insertion.active = true;
    rp.insertion.placed = 672;
    rp.insertion.waves = 2;
    rp.insertion.empty_waves = 1;
    rp.insertion.fall_step = 201;
    rp.insertion.rng = g;
  });
  {
    sim::Simulation s = fuzz::make_scene();
    auto rp = checkpoint::load_checkpoint_bytes(b, "run/checkpoint.bin", s);
    EXPECT_TRUE(rp.insertion.active);
    EXPECT_EQ(rp.insertion.placed, 672u);
    EXPECT_EQ(rp.insertion.waves, 2u);
    EXPECT_EQ(rp.insertion.empty_waves, 1u);
    EXPECT_EQ(rp.insertion.fall_step, 201u);
    for (int k = 0; k < 10; ++k) EXPECT_EQ(rp.insertion.rng(), g());
  }
  // The generator's text is the last field of version 5, followed by version 6's two strings (empty
  // here: 8 bytes of length each): its first character made a letter.
  const std::size_t payload = b.size() - kHead - 8, at = kHead + payload - 16 - text.str().size();
  ASSERT_EQ(std::string(b.data() + at, text.str().size()), text.str());
  b[at] = 'x';
  rewrap(b, checkpoint::kCheckpointVersion, payload);
  expect_one_line_error(load_error(b), "insertion random state");
}
