# Installs blobvk into a fresh prefix, then configures, builds and runs consumers against it with
# find_package(blobvk COMPONENTS ...): proves the package, its components and its headers work
# from an installed tree. Run by CTest (tests/install/CMakeLists.txt):
#   cmake -DBUILD_DIR=... -DSOURCE_DIR=... -DTESTS_DIR=... -DWORK_DIR=... [-DWITH_VK=ON]
#         [-DCPU_ONLY_BUILD=ON] -P install_test.cmake
# CPU_ONLY_BUILD: first configure and build blobvk's libraries with -DBLOBVK_WITH_VULKAN=OFF (a
# full compile of the CPU libraries: minutes on 2 cores, hence the `slow` label).
# Everything but a CPU-only blobvk build starts afresh (that build is incremental when rerun).
file(GLOB old_outputs ${WORK_DIR}/*)
list(REMOVE_ITEM old_outputs ${WORK_DIR}/blobvk)
if(old_outputs)
  file(REMOVE_RECURSE ${old_outputs})
endif()
file(MAKE_DIRECTORY ${WORK_DIR})
function(run)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "failed (${rc}): ${ARGN}\n${out}\n${err}")
  endif()
  set(run_output "${out}${err}" PARENT_SCOPE)
endfunction()

set(prefix ${WORK_DIR}/prefix)
set(launcher)
find_program(CCACHE ccache)
if(CCACHE)
  set(launcher -DCMAKE_CXX_COMPILER_LAUNCHER=${CCACHE})
endif()
if(CPU_ONLY_BUILD)
  run(${CMAKE_COMMAND} -S ${SOURCE_DIR} -B ${WORK_DIR}/blobvk -G Ninja -DCMAKE_BUILD_TYPE=Release
      -DCMAKE_CXX_COMPILER=${CXX_COMPILER} ${launcher} -DBLOBVK_WITH_VULKAN=OFF -DBLOBVK_BUILD_TESTS=OFF
      -DBLOBVK_BUILD_BENCH=OFF)
  # The libraries only (not the CLI), installed component by component.
  run(${CMAKE_COMMAND} --build ${WORK_DIR}/blobvk -j 2 --target blobvk_cpu blobvk_sim blobvk_cutting blobvk_surgery)
  foreach(component blobtree mesh cpu fem cutting surgery)
    run(${CMAKE_COMMAND} --install ${WORK_DIR}/blobvk --prefix ${prefix} --component ${component})
  endforeach()
  if(EXISTS ${prefix}/lib/cmake/blobvk/blobvk-vk-targets.cmake OR EXISTS ${prefix}/include/blobvk/vulkan.h)
    message(FATAL_ERROR "a BLOBVK_WITH_VULKAN=OFF build installed the vk component")
  endif()
else()
  run(${CMAKE_COMMAND} --install ${BUILD_DIR} --prefix ${prefix})
endif()

# Public headers live under include/blobvk/<room>/ only: nothing at the top of include/ but blobvk/.
file(GLOB top RELATIVE ${prefix}/include ${prefix}/include/*)
if(NOT top STREQUAL "blobvk")
  message(FATAL_ERROR "the installed include/ holds ${top}; expected only blobvk/")
endif()

# The exported targets name their external libraries by imported target, never by a path of the
# build machine (a moved prefix or another machine would link a file that is not there), and
# carry no empty link entries.
file(GLOB exports ${prefix}/lib/cmake/blobvk/blobvk-*-targets.cmake)
foreach(f ${exports})
  file(STRINGS ${f} links REGEX "INTERFACE_LINK_LIBRARIES")
  if(links MATCHES "\"/|;/|\\$<LINK_ONLY:>")
    message(FATAL_ERROR "${f} links a path or an empty entry: ${links}")
  endif()
endforeach()

# Every installed header's includes resolve inside the installed tree with include/ alone on the
# path (the preprocessor only: a header of one room may need another room's compile definitions).
file(GLOB rooms LIST_DIRECTORIES true RELATIVE ${prefix}/include/blobvk ${prefix}/include/blobvk/*)
foreach(room ${rooms})
  if(NOT IS_DIRECTORY ${prefix}/include/blobvk/${room})
    continue()
  endif()
  file(GLOB headers RELATIVE ${prefix}/include ${prefix}/include/blobvk/${room}/*.h)
  set(tu "")
  foreach(h ${headers})
    string(APPEND tu "#include <${h}>\n")
  endforeach()
  file(WRITE ${WORK_DIR}/headers_${room}.cpp "${tu}")
  run(${CXX_COMPILER} -std=c++20 -E -I${prefix}/include -I/usr/include/eigen3 ${WORK_DIR}/headers_${room}.cpp -o ${WORK_DIR}/headers_${room}.i)
endforeach()

# A sphere for the consumers: one point primitive of support 2 (radius 2 * 0.4542).
file(WRITE ${WORK_DIR}/sphere.json [[{"blobvk": 1, "name": "sphere", "root": {"type": "point", "support": 2}}]])

# Consumers must not need Vulkan, glslang or SPIRV-Tools: finding them is disabled outright.
set(no_vulkan -DCMAKE_DISABLE_FIND_PACKAGE_Vulkan=ON -DCMAKE_DISABLE_FIND_PACKAGE_glslang=ON
              -DCMAKE_DISABLE_FIND_PACKAGE_SPIRV-Tools-opt=ON)
foreach(consumer cpu_consumer fem_consumer)
  run(${CMAKE_COMMAND} -S ${TESTS_DIR}/${consumer} -B ${WORK_DIR}/${consumer} -G Ninja -DCMAKE_BUILD_TYPE=Release
      -DCMAKE_CXX_COMPILER=${CXX_COMPILER} ${launcher} -DCMAKE_PREFIX_PATH=${prefix} ${no_vulkan})
  run(${CMAKE_COMMAND} --build ${WORK_DIR}/${consumer} -j 2)
  run(${WORK_DIR}/${consumer}/${consumer} ${WORK_DIR}/sphere.json)
  message("${consumer}: ${run_output}")
endforeach()
# The surgery host (examples/cut_host): COMPONENTS surgery, cuts the soft peanut in two.
run(${CMAKE_COMMAND} -S ${SOURCE_DIR}/examples/cut_host -B ${WORK_DIR}/cut_host -G Ninja -DCMAKE_BUILD_TYPE=Release
    -DCMAKE_CXX_COMPILER=${CXX_COMPILER} ${launcher} -DCMAKE_PREFIX_PATH=${prefix} ${no_vulkan})
run(${CMAKE_COMMAND} --build ${WORK_DIR}/cut_host -j 2)
run(${WORK_DIR}/cut_host/cut_host ${SOURCE_DIR}/scenes/soft_peanut.json)
message("cut_host: ${run_output}")
if(CPU_ONLY_BUILD)
  return()
endif()

# Asking a package for a component it does not have fails at configure time with the reason.
file(MAKE_DIRECTORY ${WORK_DIR}/bad_component)
file(WRITE ${WORK_DIR}/bad_component/CMakeLists.txt
  "cmake_minimum_required(VERSION 3.25)\nproject(bad LANGUAGES CXX)\nfind_package(blobvk REQUIRED COMPONENTS vk)\n")
execute_process(COMMAND ${CMAKE_COMMAND} -S ${WORK_DIR}/bad_component -B ${WORK_DIR}/bad_component/build
                -DCMAKE_PREFIX_PATH=${prefix} ${no_vulkan} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(rc EQUAL 0 OR NOT "${out}${err}" MATCHES "blobvk component vk")
  message(FATAL_ERROR "find_package(blobvk COMPONENTS vk) without Vulkan should fail naming the component:\n${out}\n${err}")
endif()

if(WITH_VK)
  run(${CMAKE_COMMAND} -S ${SOURCE_DIR}/examples/embed_host -B ${WORK_DIR}/embed_host -G Ninja
      -DCMAKE_BUILD_TYPE=Release -DCMAKE_CXX_COMPILER=${CXX_COMPILER} ${launcher} -DCMAKE_PREFIX_PATH=${prefix})
  run(${CMAKE_COMMAND} --build ${WORK_DIR}/embed_host -j 2)
  execute_process(COMMAND ${WORK_DIR}/embed_host/embed_host --validation --output ${WORK_DIR}/embed_host.png
                  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "installed embed_host failed (${rc}):\n${out}\n${err}")
  endif()
  message("embed_host: ${out}")
endif()
