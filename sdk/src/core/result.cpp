// Errors as values: the names of the error codes (see penumbra/core/result.h).
#include "penumbra/core/result.h"

namespace penumbra {

const char* to_string(ErrorCode code) {
  switch (code) {
    case ErrorCode::InvalidArgument: return "invalid argument";
    case ErrorCode::InvalidInput: return "invalid input";
    case ErrorCode::NotFound: return "not found";
    case ErrorCode::Unsupported: return "unsupported";
    case ErrorCode::OutOfBudget: return "out of memory budget";
    case ErrorCode::Io: return "I/O error";
    case ErrorCode::Cancelled: return "cancelled";
    case ErrorCode::Internal: return "internal error";
  }
  return "unknown error";
}

}  // namespace penumbra
