# Unity builds (PSRIG_UNITY_BUILD, on unless turned off): each target's
# sources are compiled up to sixteen to a translation unit, so the heavy
# headers (OpenCV, Eigen, nlohmann/json, fmt, cpp-httplib, GoogleTest) are
# parsed, and their templates instantiated, once per batch rather than once
# per file: a fresh build takes a fraction of the time. Files of one target
# then share a translation unit, so the names in their anonymous
# namespaces must differ (the build says where they do not). For a
# developer's edit-compile loop, -DPSRIG_UNITY_BUILD=OFF with ccache
# recompiles one file instead of its batch.
set(CMAKE_UNITY_BUILD ${PSRIG_UNITY_BUILD})
set(CMAKE_UNITY_BUILD_BATCH_SIZE 16)

# cpp-httplib includes <resolv.h>, whose `_res` macro would rename a
# parameter of Eigen's headers included later in the same batch: undone
# after every source of every target below `directory`.
function(psrig_unity_build_fixups directory)
  get_property(targets DIRECTORY ${directory} PROPERTY BUILDSYSTEM_TARGETS)
  foreach(target IN LISTS targets)
    get_target_property(type ${target} TYPE)
    if(type MATCHES "^(EXECUTABLE|STATIC_LIBRARY|SHARED_LIBRARY|MODULE_LIBRARY|OBJECT_LIBRARY)$")
      set_property(TARGET ${target} PROPERTY UNITY_BUILD_CODE_AFTER_INCLUDE "#undef _res")
    endif()
  endforeach()
  get_property(subdirectories DIRECTORY ${directory} PROPERTY SUBDIRECTORIES)
  foreach(subdirectory IN LISTS subdirectories)
    psrig_unity_build_fixups(${subdirectory})
  endforeach()
endfunction()
