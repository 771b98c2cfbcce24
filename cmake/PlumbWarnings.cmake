# SPDX-License-Identifier: BSD-3-Clause
# Warnings are PRIVATE to plumb's own targets; -Werror only when PLUMB_WERROR is on (CI).
function(plumb_set_warnings target)
  if(CMAKE_CXX_COMPILER_ID MATCHES "GNU|Clang")
    target_compile_options(${target} PRIVATE -Wall -Wextra -Wpedantic -Wshadow)
    if(PLUMB_WERROR)
      target_compile_options(${target} PRIVATE -Werror)
    endif()
  endif()
endfunction()
