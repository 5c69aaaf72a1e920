# hedgefit_library(NAME SOURCES file... [HEADERS file...])
# One of hedgefit's libraries: target hedgefit_NAME (alias hedgefit::NAME, exported as NAME),
# its folder on the include path as "NAME/header.hpp", hedgefit's warnings on its own sources,
# installed with HEADERS under include/hedgefit/NAME. Link it to its dependencies after the call.
function(hedgefit_library name)
  cmake_parse_arguments(LIB "" "" "SOURCES;HEADERS" ${ARGN})
  add_library(hedgefit_${name} ${LIB_SOURCES})
  add_library(hedgefit::${name} ALIAS hedgefit_${name})
  set_target_properties(hedgefit_${name} PROPERTIES EXPORT_NAME ${name} OUTPUT_NAME hedgefit_${name})
  target_include_directories(hedgefit_${name} PUBLIC
    $<BUILD_INTERFACE:${PROJECT_SOURCE_DIR}>
    $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}/hedgefit>)
  target_link_libraries(hedgefit_${name} PRIVATE $<BUILD_INTERFACE:hedgefit_warnings>)
  install(TARGETS hedgefit_${name} EXPORT hedgefitTargets
    LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR} ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR})
  if(LIB_HEADERS)
    install(FILES ${LIB_HEADERS} DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/hedgefit/${name})
  endif()
endfunction()
