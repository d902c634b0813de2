// Status propagation macros, in the style of abseil's internal ones (which
// this abseil version does not ship).
//
//   RETURN_IF_ERROR(DoThing());
//   ASSIGN_OR_RETURN(Image image, ReadImage(path));
//
// Use StatusWithContext() to add a prefix where a plain return is not enough.
#ifndef POINTFORWARD_COMMON_STATUS_MACROS_H_
#define POINTFORWARD_COMMON_STATUS_MACROS_H_

#include <utility>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/string_view.h"

namespace pf {

// Returns `status` with `context + ": "` put before its message; OK stays OK.
inline absl::Status StatusWithContext(const absl::Status& status, absl::string_view context) {
  if (status.ok()) return status;
  return absl::Status(status.code(), absl::StrCat(context, ": ", status.message()));
}

}  // namespace pf

#define PF_STATUS_CONCAT_INNER_(a, b) a##b
#define PF_STATUS_CONCAT_(a, b) PF_STATUS_CONCAT_INNER_(a, b)

// Evaluates `expr` (an absl::Status) and returns it from the caller if not OK.
#define RETURN_IF_ERROR(expr)                \
  do {                                       \
    ::absl::Status pf_status_ = (expr);      \
    if (!pf_status_.ok()) return pf_status_; \
  } while (false)

// Evaluates `rexpr` (an absl::StatusOr<T>); returns its status if not OK,
// else moves its value into `lhs` (a declaration or an lvalue).
#define ASSIGN_OR_RETURN(lhs, rexpr) \
  PF_ASSIGN_OR_RETURN_IMPL_(PF_STATUS_CONCAT_(pf_statusor_, __LINE__), lhs, rexpr)

#define PF_ASSIGN_OR_RETURN_IMPL_(statusor, lhs, rexpr)    \
  auto statusor = (rexpr);                                 \
  if (!statusor.ok()) return std::move(statusor).status(); \
  lhs = std::move(statusor).value()

#endif  // POINTFORWARD_COMMON_STATUS_MACROS_H_
