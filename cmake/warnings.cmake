# One interface target carries the project's warning flags; every target links it.
add_library(tetrascope_warnings INTERFACE)
add_library(tetrascope::warnings ALIAS tetrascope_warnings)
target_compile_options(tetrascope_warnings INTERFACE -Wall -Wextra -Wshadow -Wnon-virtual-dtor)
if(TETRA_WERROR)
  target_compile_options(tetrascope_warnings INTERFACE -Werror)
endif()
