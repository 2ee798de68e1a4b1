# RED_STDLIB_FIRST: every C++ source of the project's targets is compiled with the whole
# standard library included first (<bits/stdc++.h>, as a precompiled header). Newer
# standard libraries reach more of themselves through each header (libstdc++ 13 pulls
# <iomanip> in where 12 did not), so a file-local name that argument-dependent lookup can
# confuse with a std:: one compiles with g++ 12 and fails with g++ 13; with everything
# included first it fails here too. scripts/test.sh turns it on in the sanitizer builds (a
# build that compiles anyway, and compiles faster with the header precompiled), and
# scripts/check-stdlib.py checks the sources those builds leave out (LibTorch, DDS,
# benchmarks) one by one (docs/TESTING.md, "How long the test command takes").
#
# Off by default: a build without it shows a missing #include. Meant for unoptimized
# (Debug) builds: at -O3, GCC 12 reports libstdc++'s false -Warray-bounds positives inside
# std::string from a precompiled header (tests/cli/cli_test.cpp), which it keeps quiet when the
# same header is included as text.
option(RED_STDLIB_FIRST "Compile every C++ source with <bits/stdc++.h> included first (precompiled)" OFF)

# The project's targets call this through red_set_warnings (cmake/Warnings.cmake).
function(red_stdlib_first target)
  if(RED_STDLIB_FIRST)
    target_precompile_headers(${target} PRIVATE
                              "$<$<COMPILE_LANGUAGE:CXX>:<bits/stdc++.h$<ANGLE-R>>")
  endif()
endfunction()
