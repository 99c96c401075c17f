// Errors in three tiers (see docs/architecture.md):
//  - invariants: APO_CHECK aborts with the failed expression and values;
//  - untrusted input and options: Result<T> carries an Error whose message
//    names the file, the place in it and the problem;
//  - exit codes: only cli/main.cpp turns an ErrorKind into one.
#pragma once

#include <fmt/format.h>

#include <cstdio>
#include <cstdlib>
#include <exception>
#include <new>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>
#include <variant>

namespace apo {

// Values are the documented exit codes of the `apo` command.
enum class ErrorKind : int {
  Usage = 1,     // bad command line or option value
  BadInput = 2,  // an input file is missing, unreadable or malformed
  Internal = 3,  // a bug, a library failure, or an output that cannot be written
};

struct Error {
  ErrorKind kind = ErrorKind::Internal;
  std::string message;
};

template <class... Args>
Error badInput(fmt::format_string<Args...> format, Args&&... args) {
  return {ErrorKind::BadInput, fmt::format(format, std::forward<Args>(args)...)};
}
template <class... Args>
Error usageError(fmt::format_string<Args...> format, Args&&... args) {
  return {ErrorKind::Usage, fmt::format(format, std::forward<Args>(args)...)};
}
template <class... Args>
Error internalError(fmt::format_string<Args...> format, Args&&... args) {
  return {ErrorKind::Internal, fmt::format(format, std::forward<Args>(args)...)};
}

// A value or the Error that prevented it.
template <class T>
class [[nodiscard]] Result {
 public:
  Result(T value) : state_(std::move(value)) {}
  Result(Error error) : state_(std::move(error)) {}

  bool ok() const { return state_.index() == 0; }
  explicit operator bool() const { return ok(); }

  T& value() & { return std::get<0>(state_); }
  const T& value() const& { return std::get<0>(state_); }
  // By value: `for (x : f().value())` must not refer into a dead temporary.
  T value() && { return std::get<0>(std::move(state_)); }
  T* operator->() { return &value(); }
  const T* operator->() const { return &value(); }
  T& operator*() & { return value(); }
  const T& operator*() const& { return value(); }
  const Error& error() const { return std::get<1>(state_); }

 private:
  std::variant<T, Error> state_;
};

// Result of an operation that produces nothing but may fail.
struct Ok {};
using Status = Result<Ok>;
inline Status okStatus() { return Ok{}; }

namespace detail {
template <class T>
struct AsResult {
  using type = Result<T>;
};
template <class T>
struct AsResult<Result<T>> {
  using type = Result<T>;
};
template <>
struct AsResult<void> {
  using type = Status;
};
}  // namespace detail

// Runs `body`, a call into a third-party library (CGAL, PCL, FLANN, Embree,
// TBB), and turns any exception it throws into an Internal error naming
// `what`. The adapters wrap every library call in it, so that no library
// exception reaches a stage or unwinds through a worker thread. `body` may
// return a value, a Result or nothing.
template <class Body>
auto catchLibraryErrors(std::string_view what, Body&& body) ->
    typename detail::AsResult<std::invoke_result_t<Body>>::type {
  try {
    if constexpr (std::is_void_v<std::invoke_result_t<Body>>) {
      body();
      return okStatus();
    } else {
      return body();
    }
  } catch (const std::bad_alloc&) {
    return internalError("{}: out of memory", what);
  } catch (const std::exception& exception) {
    return internalError("{}: {}", what, exception.what());
  } catch (...) {
    return internalError("{}: an unknown exception", what);
  }
}

}  // namespace apo

#define APO_CHECK(cond)                                                        \
  do {                                                                         \
    if (!(cond)) {                                                             \
      std::fprintf(stderr, "%s:%d: check failed: %s\n", __FILE__, __LINE__,    \
                   #cond);                                                     \
      std::abort();                                                            \
    }                                                                          \
  } while (0)

#define APO_CHECK_OP(a, op, b)                                                 \
  do {                                                                         \
    const auto& apo_check_a_ = (a);                                            \
    const auto& apo_check_b_ = (b);                                            \
    if (!(apo_check_a_ op apo_check_b_)) {                                     \
      std::fprintf(stderr, "%s:%d: check failed: %s %s %s (%s vs %s)\n",       \
                   __FILE__, __LINE__, #a, #op, #b,                            \
                   fmt::to_string(apo_check_a_).c_str(),                       \
                   fmt::to_string(apo_check_b_).c_str());                      \
      std::abort();                                                            \
    }                                                                          \
  } while (0)

// Propagates the error of a Result/Status expression out of the enclosing
// function, which must return a Result.
#define APO_RETURN_IF_ERROR(expr)                                              \
  do {                                                                         \
    auto&& apo_status_ = (expr);                                               \
    if (!apo_status_.ok()) return apo_status_.error();                         \
  } while (0)
