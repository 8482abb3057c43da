# write_if_changed(FILE TEXT): writes TEXT to FILE unless FILE already holds exactly that, so a
# generated source that did not change is not rebuilt (included by the build-time generators).
function(write_if_changed file text)
  set(old "")
  if(EXISTS "${file}")
    file(READ "${file}" old)
  endif()
  if(NOT old STREQUAL text)
    file(WRITE "${file}" "${text}")
  endif()
endfunction()
