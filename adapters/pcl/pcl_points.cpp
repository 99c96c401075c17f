// PCL jobs over points, run by PCL's module (pcl_module.h), loaded from
// beside the running executable on the first job that needs it.
#include "adapters/pcl/pcl_points.h"

#include "adapters/pcl/pcl_module.h"

#include <dlfcn.h>

#include <algorithm>
#include <array>
#include <filesystem>
#include <string>
#include <system_error>

namespace apo::pcl_adapter {
namespace {

// apo-pcl.so in the directory of the running executable (apo-engine, as
// installed in lib/apo or built, or a test beside it in the build tree).
std::filesystem::path modulePath() {
  std::error_code failed;
  const std::filesystem::path executable = std::filesystem::read_symlink("/proc/self/exe", failed);
  return (failed ? std::filesystem::path() : executable.parent_path()) / kApoPclModuleFile;
}

// RTLD_NODELETE: the module stays mapped once loaded, so its functions
// outlive the handle, which is closed again here (a later job loads it
// again in no time: dlopen finds it loaded).
Result<const ApoPclModule*> loadModule() {
  const std::string path = modulePath().string();
  void* handle = dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL | RTLD_NODELETE);
  if (handle == nullptr)
    return internalError("cannot load PCL's module {} ({}): it is built and installed beside apo-engine", path,
                         dlerror());
  const auto entry = reinterpret_cast<const ApoPclModule* (*)()>(dlsym(handle, kApoPclModuleSymbol));
  dlclose(handle);
  if (entry == nullptr) return internalError("PCL's module {} has no {}", path, kApoPclModuleSymbol);
  const ApoPclModule* module = entry();
  if (module == nullptr || module->version != kApoPclModuleVersion)
    return internalError("PCL's module {} is of another version than apo-engine ({} against {}): reinstall apo", path,
                         module ? module->version : 0, kApoPclModuleVersion);
  return module;
}

const float* packed(const std::vector<Vec3f>& points) {
  static_assert(sizeof(Vec3f) == 3 * sizeof(float), "Vec3f must be three packed floats");
  return points.empty() ? nullptr : points.front().data();
}

// A module call's status: `code` 0, or an Internal error naming the job.
using ErrorText = std::array<char, 512>;
Status moduleStatus(const char* job, int code, const ErrorText& error) {
  if (code == 0) return okStatus();
  return internalError("{}: {}", job, error.data());
}

}  // namespace

Result<std::vector<char>> statisticalOutlierKeepMask(const std::vector<Vec3f>& points, int k, double stdDevs) {
  auto module = loadModule();
  if (!module) return module.error();
  std::vector<char> keep(points.size(), 0);
  ErrorText error{};
  const int code =
      (*module)->statisticalOutlierKeepMask(packed(points), points.size(), k, stdDevs, keep.data(), error.data(), error.size());
  APO_RETURN_IF_ERROR(moduleStatus("PCL outlier removal", code, error));
  return keep;
}

Result<std::vector<std::vector<int>>> nearestNeighbours(const std::vector<Vec3f>& points,
                                                        const std::vector<std::uint32_t>& queries, int k) {
  if (k < 1) return internalError("PCL k-nearest search: k must be at least 1, got {}", k);
  auto module = loadModule();
  if (!module) return module.error();
  const auto width = static_cast<std::size_t>(k);
  std::vector<int> rows(queries.size() * width);
  ErrorText error{};
  const int code = (*module)->nearestNeighbours(packed(points), points.size(), queries.data(), queries.size(), k,
                                                rows.data(), error.data(), error.size());
  APO_RETURN_IF_ERROR(moduleStatus("PCL k-nearest search", code, error));
  std::vector<std::vector<int>> neighbours(queries.size());
  for (std::size_t q = 0; q < queries.size(); ++q) {
    const auto row = rows.begin() + static_cast<std::ptrdiff_t>(q * width);
    neighbours[q].assign(row, std::find(row, row + static_cast<std::ptrdiff_t>(width), -1));
  }
  return neighbours;
}

Result<std::vector<int>> nearestInReference(const std::vector<Vec3f>& reference, const std::vector<Vec3f>& queries) {
  auto module = loadModule();
  if (!module) return module.error();
  std::vector<int> nearest(queries.size(), -1);
  ErrorText error{};
  const int code = (*module)->nearestInReference(packed(reference), reference.size(), packed(queries), queries.size(),
                                                 nearest.data(), error.data(), error.size());
  APO_RETURN_IF_ERROR(moduleStatus("PCL nearest search", code, error));
  return nearest;
}

}  // namespace apo::pcl_adapter
