# SPDX-License-Identifier: BSD-3-Clause
# PLUMB_SANITIZE=ON builds with AddressSanitizer + UndefinedBehaviorSanitizer (no recovery).
function(plumb_set_sanitizers target)
  if(PLUMB_SANITIZE)
    target_compile_options(${target} PRIVATE -fsanitize=address,undefined -fno-sanitize-recover=all
                                             -fno-omit-frame-pointer)
    target_link_options(${target} PUBLIC -fsanitize=address,undefined)
  endif()
endfunction()
