// Inside bake: the entries a bake in bricks writes to its journal
// (BrickJournal, bake.h) as each cell or brick is done, and reads back
// when a killed bake is run again. Opaque scratch bytes, tied to one
// version of this code: an entry that does not decode is done again.
#pragma once

#include "bake/bake_steps.h"
#include "bake/l21_metric.h"
#include "bake/sampling.h"

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace apo::brick_journal {

// Pass 1: the areas of the points a cell of the brick depth owns.
struct AreaEntry {
  bake_steps::OrderFreeSum sum;
  std::uint64_t count = 0;
};

// Pass 2: a brick's build at one texel cap.
struct RecordEntry {
  std::vector<std::pair<octree::CellId, octree::LeafError>> found;
  bool complete = false;  // the build went as far as any split helps
};

// What sampling wrote into a leaf's node.
struct LeafValues {
  Vec3f normal = Vec3f::Zero();
  double weight = 0.0;
  std::array<Vec3f, 2> sides = {Vec3f::Zero(), Vec3f::Zero()};
};

// Pass 3: a brick's sampled leaves (node indices of the whole tree).
struct SampleEntry {
  std::vector<std::uint32_t> leaves;
  std::vector<LeafValues> values;                // one per leaf
  std::vector<sampling::SampleMoments> moments;  // one per leaf
  sampling::SampleCounts counts;
  std::uint64_t discsWiderThanReach = 0;
};

std::string encode(const AreaEntry& entry);
std::string encode(const RecordEntry& entry);
std::string encode(const SampleEntry& entry);
std::optional<AreaEntry> decodeArea(std::string_view bytes);
std::optional<RecordEntry> decodeRecords(std::string_view bytes);
std::optional<SampleEntry> decodeSamples(std::string_view bytes);

// The entries' names: one per cell of pass 1, per brick and cap of pass 2,
// per brick of pass 3.
std::string areaName(octree::CellId cell);
std::string recordsName(octree::CellId brick, std::uint64_t cap);
std::string samplesName(octree::CellId brick);

}  // namespace apo::brick_journal
