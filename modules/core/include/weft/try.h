// WEFT_TRY: forwards a failed weft::Result to the caller, so a function that creates several
// things reads as what it creates. A macro because C++ has no `?` operator (Rust) and a
// module cannot export macros: include this header in the global module fragment.
//
//   WEFT_TRY(auto layout, device.create_pipeline_layout({...}));   // layout is the value
//   WEFT_TRY_VOID(queue.write_buffer(buffer, 0, bytes));           // Result<void>
//
// The enclosing function must return a Result (any value type): the error converts through
// std::unexpected. WEFT_TRY declares a variable, so it is several statements: give an `if`
// around it braces.
#pragma once
#include <expected>
#include <utility>

#define WEFT_TRY_CONCAT_INNER(a, b) a##b
#define WEFT_TRY_CONCAT(a, b) WEFT_TRY_CONCAT_INNER(a, b)

#define WEFT_TRY_IMPL(tmp, decl, expr)                                  \
  auto tmp = (expr);                                                    \
  if (!tmp) return std::unexpected(std::move(tmp).error());             \
  decl = std::move(*tmp)

#define WEFT_TRY(decl, expr) WEFT_TRY_IMPL(WEFT_TRY_CONCAT(weft_try_, __LINE__), decl, expr)

#define WEFT_TRY_VOID(expr)                                                          \
  do {                                                                               \
    if (auto weft_try_ok = (expr); !weft_try_ok)                                     \
      return std::unexpected(std::move(weft_try_ok).error());                        \
  } while (false)
