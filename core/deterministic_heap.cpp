// The deterministic heap and the replaceable global allocation functions
// that route to it. Replacing `operator new` is process-wide by nature: the
// state below is the one global state of the code base, and it is only ever
// reached through DeterministicHeapScope (opened by the CGAL adapters around
// advancing front and scale space). Every program linking apo_core takes
// this file, as the replaced `operator new` pulls it from the archive: outside
// a scope each allocation costs one thread-local test before malloc.
#include "core/deterministic_heap.h"

#include <sys/mman.h>

#include <array>
#include <atomic>
#include <bit>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <new>

namespace apo {
namespace {

// Address space reserved once, without memory (PROT_NONE): regions of 32
// GiB, enough for any one call of a library the scopes guard.
constexpr std::size_t kRegions = 4;
constexpr std::size_t kRegionBytes = std::size_t{32} << 30;
// Memory is committed (made readable and writable) this much at a time.
constexpr std::size_t kCommitStep = std::size_t{64} << 20;
// Every block starts with a header of this size, which keeps payloads
// aligned as malloc's are.
constexpr std::size_t kHeader = 16;
// Size classes: multiples of 16 bytes up to 1 KiB, then powers of two.
constexpr std::size_t kSmallLimit = 1024;
constexpr std::size_t kSmallClasses = kSmallLimit / 16;
constexpr std::size_t kClasses = kSmallClasses + 64;

std::size_t classOf(std::size_t bytes) {
  if (bytes == 0) bytes = 1;
  if (bytes <= kSmallLimit) return (bytes + 15) / 16 - 1;
  return kSmallClasses + static_cast<std::size_t>(std::bit_width(bytes - 1)) - 11;  // 1025..2048 -> first
}

std::size_t bytesOfClass(std::size_t cls) {
  if (cls < kSmallClasses) return (cls + 1) * 16;
  return std::size_t{1} << (cls - kSmallClasses + 11);
}

struct FreeBlock {
  FreeBlock* next;
};

struct Region {
  std::atomic_flag lock = ATOMIC_FLAG_INIT;
  std::atomic<bool> taken{false};
  char* begin = nullptr;
  char* bump = nullptr;       // next unused byte
  char* committed = nullptr;  // end of the readable and writable part
  std::size_t live = 0;       // blocks handed out and not freed
  bool open = false;          // a scope is open on it
  std::array<FreeBlock*, kClasses> freeBlocks{};

  void acquire() {
    while (lock.test_and_set(std::memory_order_acquire)) {
    }
  }
  void release() { lock.clear(std::memory_order_release); }

  // Called with the lock held.
  void* allocate(std::size_t bytes) {
    const std::size_t cls = classOf(bytes);
    char* block = nullptr;
    if (FreeBlock* reused = freeBlocks[cls]) {
      freeBlocks[cls] = reused->next;
      block = reinterpret_cast<char*>(reused) - kHeader;
    } else {
      const std::size_t need = kHeader + bytesOfClass(cls);
      if (need > static_cast<std::size_t>(begin + kRegionBytes - bump)) return nullptr;
      if (bump + need > committed) {
        const std::size_t grow = (static_cast<std::size_t>(bump + need - committed) + kCommitStep - 1) / kCommitStep * kCommitStep;
        const std::size_t allowed = std::min(grow, static_cast<std::size_t>(begin + kRegionBytes - committed));
        if (mprotect(committed, allowed, PROT_READ | PROT_WRITE) != 0) return nullptr;
        committed += allowed;
      }
      block = bump;
      bump += need;
      *reinterpret_cast<std::uint64_t*>(block) = cls;
    }
    ++live;
    return block + kHeader;
  }

  // Called with the lock held.
  void free(void* pointer) {
    char* block = static_cast<char*>(pointer) - kHeader;
    const std::size_t cls = *reinterpret_cast<const std::uint64_t*>(block);
    auto* freed = static_cast<FreeBlock*>(pointer);
    freed->next = freeBlocks[cls];
    freeBlocks[cls] = freed;
    --live;
  }

  // Gives the memory back and the region up. Called with the lock held,
  // when no scope is open on it and nothing of it is live.
  void reset() {
    if (committed > begin) {
      madvise(begin, static_cast<std::size_t>(committed - begin), MADV_DONTNEED);
      mprotect(begin, static_cast<std::size_t>(committed - begin), PROT_NONE);
    }
    bump = committed = begin;
    freeBlocks.fill(nullptr);
    taken.store(false, std::memory_order_release);
  }
};

std::array<Region, kRegions> gRegions;
std::atomic<char*> gReserved{nullptr};
std::atomic_flag gReserving = ATOMIC_FLAG_INIT;
thread_local int tOpenRegion = -1;

// The reservation, made by the first scope; null when refused.
char* reservation() {
  if (char* base = gReserved.load(std::memory_order_acquire)) return base;
  while (gReserving.test_and_set(std::memory_order_acquire)) {
  }
  char* base = gReserved.load(std::memory_order_relaxed);
  if (!base) {
    void* mapped = mmap(nullptr, kRegions * kRegionBytes, PROT_NONE, MAP_PRIVATE | MAP_ANONYMOUS | MAP_NORESERVE, -1, 0);
    if (mapped != MAP_FAILED) {
      base = static_cast<char*>(mapped);
      for (std::size_t r = 0; r < kRegions; ++r) gRegions[r].begin = gRegions[r].bump = gRegions[r].committed =
                                                      base + r * kRegionBytes;
      gReserved.store(base, std::memory_order_release);
    }
  }
  gReserving.clear(std::memory_order_release);
  return base;
}

// The region holding the pointer, or null for malloc's memory.
Region* regionOf(const void* pointer) {
  const char* base = gReserved.load(std::memory_order_acquire);
  if (!base || pointer < base) return nullptr;
  const std::size_t offset = static_cast<std::size_t>(static_cast<const char*>(pointer) - base);
  return offset < kRegions * kRegionBytes ? &gRegions[offset / kRegionBytes] : nullptr;
}

void* allocateFromOpenRegion(std::size_t bytes) {
  Region& region = gRegions[static_cast<std::size_t>(tOpenRegion)];
  region.acquire();
  void* pointer = region.allocate(bytes);
  region.release();
  return pointer;
}

void freeAnywhere(void* pointer) {
  if (!pointer) return;
  Region* region = regionOf(pointer);
  if (!region) {
    std::free(pointer);
    return;
  }
  region->acquire();
  region->free(pointer);
  if (!region->open && region->live == 0) region->reset();
  region->release();
}

// operator new's contract: retry through the new-handler, else bad_alloc.
void* allocateOrThrow(std::size_t bytes) {
  for (;;) {
    void* pointer = tOpenRegion >= 0 ? allocateFromOpenRegion(bytes) : std::malloc(bytes == 0 ? 1 : bytes);
    if (pointer) return pointer;
    std::new_handler handler = std::get_new_handler();
    if (!handler) throw std::bad_alloc();
    handler();
  }
}

void* allocateAlignedOrThrow(std::size_t bytes, std::align_val_t alignment) {
  const auto align = static_cast<std::size_t>(alignment);
  if (align <= kHeader) return allocateOrThrow(bytes);
  // Over-aligned blocks (none in the libraries guarded) come from malloc.
  for (;;) {
    if (void* pointer = std::aligned_alloc(align, (bytes + align - 1) / align * align)) return pointer;
    std::new_handler handler = std::get_new_handler();
    if (!handler) throw std::bad_alloc();
    handler();
  }
}

}  // namespace

DeterministicHeapScope::DeterministicHeapScope() : previous_(tOpenRegion) {
  if (!reservation()) return;
  for (std::size_t r = 0; r < kRegions; ++r) {
    bool expected = false;
    if (gRegions[r].taken.compare_exchange_strong(expected, true, std::memory_order_acq_rel)) {
      gRegions[r].acquire();
      gRegions[r].open = true;
      gRegions[r].release();
      region_ = static_cast<int>(r);
      tOpenRegion = region_;
      return;
    }
  }
}

DeterministicHeapScope::~DeterministicHeapScope() {
  if (region_ < 0) return;
  tOpenRegion = previous_;
  Region& region = gRegions[static_cast<std::size_t>(region_)];
  region.acquire();
  region.open = false;
  if (region.live == 0) region.reset();
  region.release();
}

}  // namespace apo

// The replaceable global allocation functions ([new.delete]).
void* operator new(std::size_t bytes) { return apo::allocateOrThrow(bytes); }
void* operator new[](std::size_t bytes) { return apo::allocateOrThrow(bytes); }
void* operator new(std::size_t bytes, const std::nothrow_t&) noexcept {
  try {
    return apo::allocateOrThrow(bytes);
  } catch (...) {
    return nullptr;
  }
}
void* operator new[](std::size_t bytes, const std::nothrow_t&) noexcept {
  try {
    return apo::allocateOrThrow(bytes);
  } catch (...) {
    return nullptr;
  }
}
void* operator new(std::size_t bytes, std::align_val_t alignment) { return apo::allocateAlignedOrThrow(bytes, alignment); }
void* operator new[](std::size_t bytes, std::align_val_t alignment) {
  return apo::allocateAlignedOrThrow(bytes, alignment);
}
void operator delete(void* pointer) noexcept { apo::freeAnywhere(pointer); }
void operator delete[](void* pointer) noexcept { apo::freeAnywhere(pointer); }
void operator delete(void* pointer, std::size_t) noexcept { apo::freeAnywhere(pointer); }
void operator delete[](void* pointer, std::size_t) noexcept { apo::freeAnywhere(pointer); }
void operator delete(void* pointer, const std::nothrow_t&) noexcept { apo::freeAnywhere(pointer); }
void operator delete[](void* pointer, const std::nothrow_t&) noexcept { apo::freeAnywhere(pointer); }
void operator delete(void* pointer, std::align_val_t) noexcept { apo::freeAnywhere(pointer); }
void operator delete[](void* pointer, std::align_val_t) noexcept { apo::freeAnywhere(pointer); }
void operator delete(void* pointer, std::size_t, std::align_val_t) noexcept { apo::freeAnywhere(pointer); }
void operator delete[](void* pointer, std::size_t, std::align_val_t) noexcept { apo::freeAnywhere(pointer); }
