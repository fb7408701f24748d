# Run at every build (the biodem_build_info target): writes OUT, the C++ source of
# output::build_description(), with the source tree's git commit ("-modified" when tracked files
# differ from it) and the build settings passed in by CMakeLists.txt. configure_file rewrites OUT
# only when its text changes, so an unchanged tree recompiles nothing.
set(BIODEM_SOURCE_COMMIT "not a git checkout")
set(ENV{GIT_OPTIONAL_LOCKS} 0)  # (git status must not take the index lock a concurrent commit needs)
find_package(Git QUIET)
if(GIT_FOUND AND EXISTS "${SRC}/.git")
  execute_process(COMMAND "${GIT_EXECUTABLE}" -C "${SRC}" rev-parse --short=12 HEAD OUTPUT_VARIABLE commit
                  RESULT_VARIABLE rc OUTPUT_STRIP_TRAILING_WHITESPACE ERROR_QUIET)
  if(rc EQUAL 0)
    set(BIODEM_SOURCE_COMMIT "${commit}")
    execute_process(COMMAND "${GIT_EXECUTABLE}" -C "${SRC}" status --porcelain --untracked-files=no
                    OUTPUT_VARIABLE changes RESULT_VARIABLE rc ERROR_QUIET)
    if(NOT rc EQUAL 0)
      set(BIODEM_SOURCE_COMMIT "${commit}-unknown-state")
    elseif(changes)
      set(BIODEM_SOURCE_COMMIT "${commit}-modified")
    endif()
  endif()
endif()
configure_file("${SRC}/cmake/build_info.cpp.in" "${OUT}" @ONLY)
