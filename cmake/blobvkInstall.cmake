# Install rules and the CMake package: find_package(blobvk COMPONENTS blobtree mesh cpu vk fem
# cutting surgery). Each component is one library with its own exported targets file
# (blobvk-<component>-targets.cmake); blobvkConfig.cmake loads the requested components, the
# blobvk components they build on, and only their external dependencies (Vulkan, glslang and
# SPIRV-Tools for vk alone; Eigen, and libtet where built with TetGen, for fem; TBB for cpu and fem;
# nlohmann-json for surgery). Public headers install under
# include/blobvk/<room>/ next to the entry headers include/blobvk/blobvk.h and vulkan.h.
# tests/install builds consumers against an installed tree.
include(GNUInstallDirs)
include(CMakePackageConfigHelpers)

# component -> targets, and the blobvk components it needs (blobvkConfig.cmake.in repeats the
# dependency lists for the consumer's side).
set(blobvk_component_blobtree_targets blobvk_layout blobvk_blobtree)
set(blobvk_component_mesh_targets blobvk_mesh)
set(blobvk_component_cpu_targets blobvk_cpu)
set(blobvk_component_vk_targets blobvk_vk)
set(blobvk_component_fem_targets blobvk_sim)
set(blobvk_component_cutting_targets blobvk_cutting)
set(blobvk_component_surgery_targets blobvk_surgery)
# component -> source folders whose headers it installs
set(blobvk_component_blobtree_headers blobtree shaders)
set(blobvk_component_mesh_headers mesh)
set(blobvk_component_cpu_headers cpu_simd)
set(blobvk_component_vk_headers vk)
set(blobvk_component_fem_headers fem)
set(blobvk_component_cutting_headers cutting)
set(blobvk_component_surgery_headers surgery)

set(BLOBVK_INSTALLED_COMPONENTS)
foreach(component blobtree mesh cpu vk fem cutting surgery)
  set(targets)
  foreach(target ${blobvk_component_${component}_targets})
    if(TARGET ${target})
      list(APPEND targets ${target})
    endif()
  endforeach()
  if(NOT targets)
    continue()  # not built (vk with BLOBVK_WITH_VULKAN=OFF)
  endif()
  list(APPEND BLOBVK_INSTALLED_COMPONENTS ${component})
  foreach(target ${targets})
    # blobvk::<component> for the component's library (blobvk_sim exports as blobvk::fem).
    string(REPLACE "blobvk_" "" export_name ${target})
    if(target STREQUAL "blobvk_sim")
      set(export_name fem)
    endif()
    set_target_properties(${target} PROPERTIES EXPORT_NAME ${export_name})
    get_target_property(target_type ${target} TYPE)
    set(scope PUBLIC)
    if(target_type STREQUAL "INTERFACE_LIBRARY")
      set(scope INTERFACE)
    endif()
    foreach(dir ${BLOBVK_INSTALL_INCLUDE_DIRS})
      target_include_directories(${target} ${scope} $<INSTALL_INTERFACE:${dir}>)
    endforeach()
  endforeach()
  install(TARGETS ${targets} EXPORT blobvk-${component}-targets COMPONENT ${component}
          ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
          LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR})
  install(EXPORT blobvk-${component}-targets NAMESPACE blobvk:: COMPONENT ${component}
          DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/blobvk)
  foreach(dir ${blobvk_component_${component}_headers})
    install(DIRECTORY ${PROJECT_SOURCE_DIR}/${dir}/ DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/blobvk/${dir}
            COMPONENT ${component} FILES_MATCHING PATTERN "*.h"
            PATTERN "engine" EXCLUDE)  # mesh/engine (glTF, meshoptimizer) is the CLI's, not installed
  endforeach()
endforeach()
install(FILES ${PROJECT_SOURCE_DIR}/include/blobvk/blobvk.h DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/blobvk COMPONENT blobtree)
if(TARGET blobvk_vk)
  install(FILES ${PROJECT_SOURCE_DIR}/include/blobvk/vulkan.h DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/blobvk COMPONENT vk)
endif()

configure_package_config_file(cmake/blobvkConfig.cmake.in
  ${CMAKE_CURRENT_BINARY_DIR}/blobvkConfig.cmake
  INSTALL_DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/blobvk)
write_basic_package_version_file(${CMAKE_CURRENT_BINARY_DIR}/blobvkConfigVersion.cmake
  COMPATIBILITY SameMinorVersion)
# The package files go with blobtree, which every other component builds on; the blobvk tool is the
# `cli` install component (`cmake --install . --component cpu` and friends install one library).
install(FILES ${CMAKE_CURRENT_BINARY_DIR}/blobvkConfig.cmake ${CMAKE_CURRENT_BINARY_DIR}/blobvkConfigVersion.cmake
        DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/blobvk COMPONENT blobtree)
