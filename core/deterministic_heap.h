// A heap whose addresses depend only on the sequence of allocations made in
// it, for libraries whose results depend on the order of addresses.
//
// CGAL's advancing front orders its candidate edges by (priority, address of
// the edge's record) and many priorities tie, so its surface depended on the
// state of the process's heap: `apo run` and `apo reconstruct` on the same
// points made different meshes (281,054 and 281,070 triangles on
// table_scene_lms400), and a run could differ from the one before it. While
// a scope is open, this thread's `operator new` takes memory from a private
// region of reserved address space, handed out in increasing order and
// reused in a fixed order, so the same calls get addresses in the same
// order in any process, whatever ran before.
#pragma once

#include <optional>

namespace apo {

class DeterministicHeapScope {
 public:
  // Opens the scope on this thread (nested scopes take regions of their own).
  // Allocations made after the scope closes come from malloc again; memory
  // taken in the scope may be freed at any time, from any thread, and the
  // region is given back when the last of it is freed.
  DeterministicHeapScope();
  ~DeterministicHeapScope();
  DeterministicHeapScope(const DeterministicHeapScope&) = delete;
  DeterministicHeapScope& operator=(const DeterministicHeapScope&) = delete;

  // False when no region could be had (address space refused, or every
  // region in use): allocations then come from malloc, as without a scope.
  bool active() const { return region_ >= 0; }

 private:
  int region_ = -1;
  int previous_ = -1;
};

// `make()` run in a scope, and a copy of what it returns made after the scope
// closes (so the result lives in malloc's memory, and the region is given
// back as soon as make's own objects are gone).
template <class Make>
auto madeInDeterministicHeap(Make make) -> decltype(make()) {
  std::optional<DeterministicHeapScope> scope(std::in_place);
  const auto inScope = make();
  scope.reset();
  return decltype(make())(inScope);
}

}  // namespace apo
