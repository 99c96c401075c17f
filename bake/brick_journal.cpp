#include "bake/brick_journal.h"

#include <cinttypes>
#include <cstdio>
#include <cstring>
#include <type_traits>

namespace apo::brick_journal {
namespace {

// Each entry starts with its kind and this code's journal version.
constexpr char kMagic[4] = {'A', 'P', 'O', 'J'};
constexpr std::uint8_t kVersion = 1;
enum class Kind : std::uint8_t { Area = 1, Records = 2, Samples = 3 };

class Writer {
 public:
  explicit Writer(Kind kind) {
    bytes_.append(kMagic, sizeof kMagic);
    put(kind);
    put(kVersion);
  }
  template <class T>
  void put(const T& value) {
    static_assert(std::is_trivially_copyable_v<T>);
    bytes_.append(reinterpret_cast<const char*>(&value), sizeof value);
  }
  void put(const sampling::SampleMoments& m) {
    put(m.weight);
    put(m.alongCoarse);
    for (int i = 0; i < 3; ++i) put(m.sum[i]);
    for (int i = 0; i < 3; ++i) put(m.coarseSum[i]);
  }
  void put(const Vec3f& v) {
    for (int i = 0; i < 3; ++i) put(v[i]);
  }
  void put(const LeafValues& leaf) {
    put(leaf.normal);
    put(leaf.weight);
    put(leaf.sides[0]);
    put(leaf.sides[1]);
  }
  std::string take() { return std::move(bytes_); }

 private:
  std::string bytes_;
};

class Reader {
 public:
  Reader(std::string_view bytes, Kind kind) : bytes_(bytes) {
    char magic[sizeof kMagic] = {};
    Kind found{};
    std::uint8_t version = 0;
    ok_ = take(magic, sizeof magic) && std::memcmp(magic, kMagic, sizeof kMagic) == 0 && get(found) &&
          found == kind && get(version) && version == kVersion;
  }
  template <class T>
  bool get(T& value) {
    static_assert(std::is_trivially_copyable_v<T>);
    return take(&value, sizeof value);
  }
  bool get(sampling::SampleMoments& m) {
    bool ok = get(m.weight) && get(m.alongCoarse);
    for (int i = 0; i < 3; ++i) ok = ok && get(m.sum[i]);
    for (int i = 0; i < 3; ++i) ok = ok && get(m.coarseSum[i]);
    return ok;
  }
  bool get(Vec3f& v) { return get(v[0]) && get(v[1]) && get(v[2]); }
  bool get(LeafValues& leaf) { return get(leaf.normal) && get(leaf.weight) && get(leaf.sides[0]) && get(leaf.sides[1]); }
  // A count of items of `itemBytes` each, checked against the bytes left
  // (a damaged count cannot ask for more memory than the entry holds).
  bool getCount(std::uint64_t& count, std::size_t itemBytes) {
    return get(count) && count <= (bytes_.size() - at_) / itemBytes;
  }
  bool ok() const { return ok_; }
  bool atEnd() const { return at_ == bytes_.size(); }

 private:
  bool take(void* out, std::size_t size) {
    if (bytes_.size() - at_ < size) return false;
    std::memcpy(out, bytes_.data() + at_, size);
    at_ += size;
    return true;
  }
  std::string_view bytes_;
  std::size_t at_ = 0;
  bool ok_ = true;
};

constexpr std::size_t kMomentBytes = 8 * sizeof(double);
constexpr std::size_t kLeafValueBytes = 9 * sizeof(float) + sizeof(double);

}  // namespace

std::string encode(const AreaEntry& entry) {
  Writer out(Kind::Area);
  out.put(entry.sum);
  out.put(entry.count);
  return out.take();
}

std::string encode(const RecordEntry& entry) {
  Writer out(Kind::Records);
  out.put(static_cast<std::uint8_t>(entry.complete ? 1 : 0));
  out.put(static_cast<std::uint64_t>(entry.found.size()));
  for (const auto& [cell, error] : entry.found) {
    out.put(cell);
    out.put(error);
  }
  return out.take();
}

std::string encode(const SampleEntry& entry) {
  Writer out(Kind::Samples);
  out.put(entry.counts);
  out.put(entry.discsWiderThanReach);
  out.put(static_cast<std::uint64_t>(entry.leaves.size()));
  for (std::size_t i = 0; i < entry.leaves.size(); ++i) {
    out.put(entry.leaves[i]);
    out.put(entry.values[i]);
    out.put(entry.moments[i]);
  }
  return out.take();
}

std::optional<AreaEntry> decodeArea(std::string_view bytes) {
  static_assert(std::is_trivially_copyable_v<bake_steps::OrderFreeSum>);
  Reader in(bytes, Kind::Area);
  AreaEntry entry;
  if (!in.ok() || !in.get(entry.sum) || !in.get(entry.count) || !in.atEnd()) return std::nullopt;
  return entry;
}

std::optional<RecordEntry> decodeRecords(std::string_view bytes) {
  Reader in(bytes, Kind::Records);
  RecordEntry entry;
  std::uint8_t complete = 0;
  std::uint64_t count = 0;
  if (!in.ok() || !in.get(complete) || complete > 1 ||
      !in.getCount(count, sizeof(octree::CellId) + sizeof(octree::LeafError)))
    return std::nullopt;
  entry.complete = complete == 1;
  entry.found.resize(count);
  for (auto& [cell, error] : entry.found)
    if (!in.get(cell) || !in.get(error)) return std::nullopt;
  if (!in.atEnd()) return std::nullopt;
  return entry;
}

std::optional<SampleEntry> decodeSamples(std::string_view bytes) {
  Reader in(bytes, Kind::Samples);
  SampleEntry entry;
  std::uint64_t count = 0;
  if (!in.ok() || !in.get(entry.counts) || !in.get(entry.discsWiderThanReach) ||
      !in.getCount(count, sizeof(std::uint32_t) + kLeafValueBytes + kMomentBytes))
    return std::nullopt;
  entry.leaves.resize(count);
  entry.values.resize(count);
  entry.moments.resize(count);
  for (std::size_t i = 0; i < count; ++i)
    if (!in.get(entry.leaves[i]) || !in.get(entry.values[i]) || !in.get(entry.moments[i])) return std::nullopt;
  if (!in.atEnd()) return std::nullopt;
  return entry;
}

namespace {
std::string named(const char* kind, octree::CellId cell, std::uint64_t cap = 0) {
  char name[64];
  std::snprintf(name, sizeof name, "%s-%016" PRIx64 "-%" PRIu64, kind, cell, cap);
  return name;
}
}  // namespace

std::string areaName(octree::CellId cell) { return named("area", cell); }
std::string recordsName(octree::CellId brick, std::uint64_t cap) { return named("records", brick, cap); }
std::string samplesName(octree::CellId brick) { return named("samples", brick); }

}  // namespace apo::brick_journal
