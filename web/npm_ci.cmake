# Installs the page's npm packages (web/package-lock.json) into web/node_modules when they are
# missing or the lock file changed, then copies the files the page serves into OUT_DIR.
# No network is needed when web/node_modules is already up to date. scripts/setup.sh runs it
# without OUT_DIR (only the npm ci), so that the build itself needs no network.
#   cmake -DNPM=npm -DWEB_DIR=web [-DOUT_DIR=dir -DFILES="three/build/three.module.js|..."] -P npm_ci.cmake
string(REPLACE "|" ";" FILES "${FILES}")
set(_modules ${WEB_DIR}/node_modules)
set(_stamp ${_modules}/.qjulia-package-lock.json)  # the lock file node_modules was installed from
set(_fresh TRUE)
if(EXISTS ${_stamp})
  file(SHA256 ${_stamp} _installed)
  file(SHA256 ${WEB_DIR}/package-lock.json _wanted)
  if(NOT _installed STREQUAL _wanted)
    set(_fresh FALSE)
  endif()
else()
  set(_fresh FALSE)
endif()
foreach(_f IN LISTS FILES)
  if(NOT EXISTS ${_modules}/${_f})
    set(_fresh FALSE)
  endif()
endforeach()

if(NOT _fresh)
  if(NOT NPM)
    message(FATAL_ERROR "qjulia explore: npm is needed once to fetch the page's packages into "
                        "${_modules} (scripts/setup.sh installs Node.js and npm)")
  endif()
  message(STATUS "qjulia explore: npm ci in ${WEB_DIR}")
  execute_process(COMMAND ${NPM} ci --no-audit --no-fund --loglevel=error
                  WORKING_DIRECTORY ${WEB_DIR} RESULT_VARIABLE _rc)
  if(NOT _rc EQUAL 0)
    message(FATAL_ERROR "qjulia explore: 'npm ci' in ${WEB_DIR} failed (${_rc}); it needs the npm "
                        "registry once, afterwards ${_modules} is reused")
  endif()
  configure_file(${WEB_DIR}/package-lock.json ${_stamp} COPYONLY)
endif()

if(NOT OUT_DIR)
  return()
endif()
foreach(_f IN LISTS FILES)
  get_filename_component(_dir ${OUT_DIR}/${_f} DIRECTORY)
  file(MAKE_DIRECTORY ${_dir})
  # A fresh copy, so the files are newer than what made this command run.
  execute_process(COMMAND ${CMAKE_COMMAND} -E copy ${_modules}/${_f} ${OUT_DIR}/${_f}
                  RESULT_VARIABLE _rc)
  if(NOT _rc EQUAL 0)
    message(FATAL_ERROR "qjulia explore: cannot copy ${_modules}/${_f} to ${OUT_DIR}")
  endif()
endforeach()
