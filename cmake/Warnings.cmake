# Warnings for the project's own targets (not for third-party headers, which are
# included as system headers).
function(red_set_warnings target)
  target_compile_options(${target} PRIVATE -Wall -Wextra -Wpedantic -Wconversion -Wshadow
                                           -Wnon-virtual-dtor -Wold-style-cast)
  if(RED_WERROR)
    target_compile_options(${target} PRIVATE -Werror)
  endif()
endfunction()
