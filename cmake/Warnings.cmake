# Warnings for the project's own targets (not for third-party headers, which are
# included as system headers).
function(red_set_warnings target)
  target_compile_options(${target} PRIVATE -Wall -Wextra -Wpedantic -Wconversion -Wshadow
                                           -Wnon-virtual-dtor -Wold-style-cast)
  # GCC 12 at -O3 reports false -Wrestrict positives inside libstdc++'s std::string
  # (GCC bug 105651); they are not in our code.
  if(CMAKE_CXX_COMPILER_ID STREQUAL "GNU" AND CMAKE_CXX_COMPILER_VERSION VERSION_LESS 13)
    target_compile_options(${target} PRIVATE -Wno-restrict)
  endif()
  # Clang (the fuzzing build) also flags private fields kept only for later use.
  if(CMAKE_CXX_COMPILER_ID STREQUAL "Clang")
    target_compile_options(${target} PRIVATE -Wno-unused-private-field)
  endif()
  if(RED_WERROR)
    target_compile_options(${target} PRIVATE -Werror)
  endif()
  red_stdlib_first(${target})  # every project target passes here (cmake/Precompile.cmake)
endfunction()
