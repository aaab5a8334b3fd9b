# Writes OUTPUT, a header that defines LANCER_GIT_COMMIT: the commit checked out in SOURCE_DIR,
# with "-dirty" when tracked files differ from it (as `git describe --dirty` marks it), or
# "unknown" outside a git checkout (a source archive) or without git. Run at every build by the
# lancer_git_commit target; the file is rewritten only when that text changes, so that a build of
# the same commit recompiles nothing.
set(commit "unknown")
if(GIT)
  execute_process(COMMAND "${GIT}" rev-parse HEAD WORKING_DIRECTORY "${SOURCE_DIR}"
                  OUTPUT_VARIABLE head OUTPUT_STRIP_TRAILING_WHITESPACE
                  RESULT_VARIABLE head_status ERROR_QUIET)
  # --no-optional-locks: a build must not take the index's lock from a git command beside it.
  execute_process(COMMAND "${GIT}" --no-optional-locks status --porcelain --untracked-files=no
                  WORKING_DIRECTORY "${SOURCE_DIR}"
                  OUTPUT_VARIABLE changes RESULT_VARIABLE status_status ERROR_QUIET)
  if(head_status EQUAL 0 AND status_status EQUAL 0)
    set(commit "${head}")
    if(NOT changes STREQUAL "")
      string(APPEND commit "-dirty")
    endif()
  endif()
endif()
string(CONCAT text "// Generated at build time by cmake/git_commit.cmake: the commit this build is of.\n"
       "#define LANCER_GIT_COMMIT \"${commit}\"\n")
set(old "")
if(EXISTS "${OUTPUT}")
  file(READ "${OUTPUT}" old)
endif()
if(NOT old STREQUAL text)
  file(WRITE "${OUTPUT}" "${text}")
endif()
