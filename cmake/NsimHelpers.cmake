# Helpers shared by every CMakeLists of the project.

# Warnings applied to every project target.
function(nsim_set_warnings target)
  target_compile_options(${target} PRIVATE
    $<$<COMPILE_LANGUAGE:CXX>:-Wall -Wextra -Wpedantic>
    $<$<AND:$<COMPILE_LANGUAGE:CXX>,$<BOOL:${NSIM_WERROR}>>:-Werror>)
endfunction()

# nsim_add_library(<name> SOURCES ... DEPS ... [PRIVATE_DEPS ...])
# Creates the static library nsim_<name> with the alias nsim::<name>; the include root is the
# repository, so headers are included as "common/<name>/file.h". DEPS are public (used by the
# headers), PRIVATE_DEPS only by the sources.
function(nsim_add_library name)
  cmake_parse_arguments(ARG "" "" "SOURCES;DEPS;PRIVATE_DEPS" ${ARGN})
  add_library(nsim_${name} STATIC ${ARG_SOURCES})
  add_library(nsim::${name} ALIAS nsim_${name})
  target_include_directories(nsim_${name} PUBLIC ${PROJECT_SOURCE_DIR})
  target_link_libraries(nsim_${name} PUBLIC ${ARG_DEPS})
  if(ARG_PRIVATE_DEPS)
    target_link_libraries(nsim_${name} PRIVATE ${ARG_PRIVATE_DEPS})
  endif()
  set_target_properties(nsim_${name} PROPERTIES POSITION_INDEPENDENT_CODE ON)
  nsim_set_warnings(nsim_${name})
endfunction()

# nsim_add_test(<file.cpp> DEPS ... [LABELS ...] [TIMEOUT s])
# One GoogleTest executable per test file, registered with ctest under the file's name.
function(nsim_add_test file)
  cmake_parse_arguments(ARG "" "TIMEOUT" "DEPS;LABELS" ${ARGN})
  get_filename_component(name ${file} NAME_WE)
  add_executable(${name} ${file})
  target_link_libraries(${name} PRIVATE ${ARG_DEPS} GTest::gtest GTest::gtest_main)
  target_compile_definitions(${name} PRIVATE
    NSIM_SOURCE_DIR="${PROJECT_SOURCE_DIR}" NSIM_BINARY_DIR="${PROJECT_BINARY_DIR}")
  set_target_properties(${name} PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${PROJECT_BINARY_DIR}/tests)
  nsim_set_warnings(${name})
  add_test(NAME ${name} COMMAND ${name})
  if(NOT ARG_TIMEOUT)
    set(ARG_TIMEOUT 300)
  endif()
  # one OpenBLAS / OpenMP thread, as the executables set for themselves (library_threads.h):
  # CHOLMOD's threads spinning against a parallel test or a batch made a 4 s test take > 300 s
  set_tests_properties(${name} PROPERTIES TIMEOUT ${ARG_TIMEOUT} LABELS "unit;${ARG_LABELS}"
    ENVIRONMENT "OPENBLAS_NUM_THREADS=1;OMP_NUM_THREADS=1;OMP_THREAD_LIMIT=1")
endfunction()

# nsim_add_benchmark(<file.cpp> DEPS ...)
function(nsim_add_benchmark file)
  cmake_parse_arguments(ARG "" "" "DEPS" ${ARGN})
  get_filename_component(name ${file} NAME_WE)
  add_executable(${name} ${file})
  target_link_libraries(${name} PRIVATE ${ARG_DEPS} benchmark::benchmark)
  target_compile_definitions(${name} PRIVATE NSIM_SOURCE_DIR="${PROJECT_SOURCE_DIR}")
  set_target_properties(${name} PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${PROJECT_BINARY_DIR}/bench)
  nsim_set_warnings(${name})
endfunction()
