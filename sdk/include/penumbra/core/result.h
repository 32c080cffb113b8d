// Errors as values. Every operation whose outcome depends on input (files, scenes, settings,
// memory budgets) returns a Result<T>; no exception crosses Penumbra's public API.
//
// An Error's message says what went wrong, where (file, element) and how to fix it, e.g.
//   "scene.gltf: accessors[3]: count 120 needs 1440 bytes but bufferViews[1] holds 960; re-export the file".
#pragma once

#include <cassert>
#include <string>
#include <utility>
#include <variant>

namespace penumbra {

enum class ErrorCode {
  InvalidArgument,  // a setting or parameter is out of range
  InvalidInput,     // a file or scene is malformed
  NotFound,         // a file, scene or named item does not exist
  Unsupported,      // valid input that Penumbra does not handle (e.g. a required glTF extension)
  OutOfBudget,      // the work would exceed the memory budget
  Io,               // reading or writing failed
  Cancelled,        // the host cancelled the work
  Internal,         // a bug in Penumbra; please report it
};

const char* to_string(ErrorCode code);

struct Error {
  ErrorCode code = ErrorCode::Internal;
  std::string message;
};

inline Error make_error(ErrorCode code, std::string message) { return Error{code, std::move(message)}; }

// Result<T>: a T or an Error. Result<void> carries only success or an Error.
template <class T>
class [[nodiscard]] Result {
 public:
  Result(T value) : v_(std::in_place_index<0>, std::move(value)) {}
  Result(Error error) : v_(std::in_place_index<1>, std::move(error)) {}

  bool ok() const { return v_.index() == 0; }
  explicit operator bool() const { return ok(); }

  T& value() & { assert(ok()); return std::get<0>(v_); }
  const T& value() const& { assert(ok()); return std::get<0>(v_); }
  T&& value() && { assert(ok()); return std::get<0>(std::move(v_)); }
  T* operator->() { return &value(); }
  const T* operator->() const { return &value(); }
  T& operator*() & { return value(); }
  const T& operator*() const& { return value(); }

  const Error& error() const { assert(!ok()); return std::get<1>(v_); }

 private:
  std::variant<T, Error> v_;
};

template <>
class [[nodiscard]] Result<void> {
 public:
  Result() = default;
  Result(Error error) : error_(std::move(error)), ok_(false) {}

  bool ok() const { return ok_; }
  explicit operator bool() const { return ok_; }
  const Error& error() const { assert(!ok_); return error_; }

 private:
  Error error_;
  bool ok_ = true;
};

using Status = Result<void>;

}  // namespace penumbra

// PENUMBRA_TRY(expr): evaluates a Result<void>-like expression and returns its Error from the
// enclosing function on failure.
#define PENUMBRA_TRY(expr)                         \
  do {                                             \
    auto penumbra_try_result_ = (expr);            \
    if (!penumbra_try_result_.ok()) return penumbra_try_result_.error(); \
  } while (0)
