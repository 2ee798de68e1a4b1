# API documentation: `cmake --build <dir> --target red_docs` runs Doxygen (Debian package
# doxygen) over the public headers, with docs/EMBEDDING.md as the main page and the
# programs in examples/ as linked examples. Not part of the default build; the HTML goes
# to <dir>/docs/api/html/index.html.
find_package(Doxygen QUIET)
if(DOXYGEN_FOUND)
  set(DOXYGEN_PROJECT_NAME "RED")
  set(DOXYGEN_PROJECT_NUMBER ${PROJECT_VERSION})
  set(DOXYGEN_PROJECT_BRIEF "${PROJECT_DESCRIPTION}")
  set(DOXYGEN_OUTPUT_DIRECTORY ${PROJECT_BINARY_DIR}/docs/api)
  set(DOXYGEN_GENERATE_HTML YES)
  set(DOXYGEN_GENERATE_LATEX NO)
  set(DOXYGEN_EXTRACT_ALL NO)
  set(DOXYGEN_JAVADOC_AUTOBRIEF YES)
  set(DOXYGEN_FULL_PATH_NAMES YES)
  set(DOXYGEN_STRIP_FROM_PATH ${PROJECT_SOURCE_DIR} ${PROJECT_BINARY_DIR})
  set(DOXYGEN_STRIP_FROM_INC_PATH ${PROJECT_SOURCE_DIR}/include ${PROJECT_BINARY_DIR}/include
                                  ${PROJECT_SOURCE_DIR}/backends/torch/include)
  set(DOXYGEN_EXAMPLE_PATH ${PROJECT_SOURCE_DIR}/examples)
  set(DOXYGEN_USE_MDFILE_AS_MAINPAGE ${PROJECT_SOURCE_DIR}/docs/EMBEDDING.md)
  set(DOXYGEN_EXCLUDE_SYMBOLS "detail" "*::Impl")
  set(DOXYGEN_WARN_IF_UNDOCUMENTED YES)
  set(DOXYGEN_WARN_LOGFILE ${PROJECT_BINARY_DIR}/docs/doxygen-warnings.log)
  set(DOXYGEN_QUIET YES)
  set(RED_DOC_INPUTS ${PROJECT_SOURCE_DIR}/docs/EMBEDDING.md ${PROJECT_SOURCE_DIR}/docs/examples.dox
                     ${PROJECT_SOURCE_DIR}/include ${PROJECT_BINARY_DIR}/include/red/version.hpp)
  foreach(dir IN ITEMS backends/torch/include bridges/dds/include)
    if(EXISTS ${PROJECT_SOURCE_DIR}/${dir})
      list(APPEND RED_DOC_INPUTS ${PROJECT_SOURCE_DIR}/${dir})
    endif()
  endforeach()
  set(DOXYGEN_FILE_PATTERNS "*.hpp" "*.md" "*.dox")
  set(DOXYGEN_EXCLUDE_PATTERNS "*.in")
  doxygen_add_docs(red_docs ${RED_DOC_INPUTS}
                   COMMENT "API documentation (Doxygen) in ${PROJECT_BINARY_DIR}/docs/api/html")
else()
  add_custom_target(red_docs COMMAND ${CMAKE_COMMAND} -E echo
                    "red_docs: Doxygen not found (apt-get install doxygen)" COMMAND false)
endif()
