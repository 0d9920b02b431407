// The subcommands of the tetrascope executable: each parses its arguments, calls the library
// that owns the work and prints the result. Each returns the exit code (2: usage); errors are
// exceptions, mapped to exit codes and messages in main.cpp.
#pragma once

#include <string>
#include <vector>

#include "tetrascope/lod/simplify/simplify.h"

namespace tetrascope::apps {

using Arguments = std::vector<std::string>;

// cmd_store.cpp: mesh and store inspection, the offline build
int run_info(const Arguments& raw);
int run_verify(const Arguments& raw);
int run_segment(const Arguments& raw);
int run_preprocess(const Arguments& raw);
// cmd_simplify.cpp: whole-mesh simplification and its error
int run_simplify(const Arguments& raw);
int run_error(const Arguments& raw);
// "qem" or "sample" given to `option`; anything else is a usage error naming both
lod::SimplifyMethod simplify_method(const std::string& value, const std::string& option);
// cmd_view.cpp: a view of a mesh or store, as a mesh (cut) or an image (render)
int run_cut(const Arguments& raw);
int run_render(const Arguments& raw);
// cmd_serve.cpp: the server and its load test
int run_serve(const Arguments& raw);
int run_loadtest(const Arguments& raw);
// cmd_streamlines.cpp: stream lines of a vector field (§7.3), diffusion surfaces of a tensor field (§7.4)
int run_streamlines(const Arguments& raw);
int run_diffusion_surfaces(const Arguments& raw);

}  // namespace tetrascope::apps
