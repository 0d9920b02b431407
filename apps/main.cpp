// The one tetrascope executable: picks the subcommand (apps/cmd_*.cpp) and maps its errors
// to exit codes (2: usage or a bad option, 1: the work failed).
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "commands.h"
#include "tetrascope/renderer/render.h"
#include "tetrascope/storage/mesh_error.h"

namespace {

constexpr const char* kUsage =
    "usage: tetrascope <command> [options]\n"
    "\n"
    "commands:\n"
    "  info MESH|STORE [--json]      counts, attributes with ranges, bounds, quality counters\n"
    "  segment MESH -o STORE [--leaf-vertices K] [--segment-tets T | --segments N] [--seed S]\n"
    "                                [--max-inflate-ratio R] [--force] [--progress bar|json|none] [--json]\n"
    "                                out-of-core segmentation (stage 1 of preprocess); the store passes verify's checks\n"
    "  preprocess MESH -o STORE [--model mt|binary] [--dependency-ratio R|off] [--base-tets B] [--segment-tets auto|T] [--min-segments S] [--variants K] [--level-ratio auto|R] [--level-targets error|ratio] [--bins N]\n"
    "                                [--threads N] [--seed S] [--force] [--progress bar|json|none] [--json]\n"
    "                                [--max-inflate-ratio R]  compressed input may inflate to R x its size + 64 MiB (100)\n"
    "                                [--simplifier qem|sample]  the levels' simplifier (qem)\n"
    "                                [--compress-segments none|index16|cutborder]  how segments.bin keeps the tets (cutborder)\n"
    "                                [--memory-mb M]  levels whose tets exceed M/4 go to a spill file beside the store (2048; 0: none)\n"
    "                                [--model mt|binary]  the multi-triangulation of §6.3 (mt), or the binary segment hierarchy\n"
    "                                of §6.2: segments merged a pair at a time, pairs whose boundary ratio is at least\n"
    "                                --dependency-ratio (0) merged with the boundary between them simplified\n"
    "                                multiresolution store: segments, levels, DAG, error histograms (§6.3);\n"
    "                                the store passes verify's checks or is removed and the command fails\n"
    "                                under `mpirun -np N` (a build with Open MPI): the levels' segments shared among N ranks,\n"
    "                                rank 0 writes the same store\n"
    "  cut STORE --budget N -o OUT.vtk [--camera C] [--size WxH] [--tf TF.json] [--attribute A] [--iso v1,v2] [--json]\n"
    "                                the adapted mesh of a view and transfer function (§6.3.4)\n"
    "  render MESH|STORE -o OUT.png|jpg [--mode dvr|iso|surface|dvr+iso|surface+iso] [--attribute A] [--tf TF.json]\n"
    "                                [--iso v1,v2] [--iso-opacity A] [--iso-color B] [--camera C] [--size WxH] [--budget TETS] [--quality Q] [--wireframe] [--box]\n"
    "                                [--hide-regions IDS|NAMES|box] [--orbit N] [--reference] [--json]   headless EGL rendering (volume, isosurfaces, boundary)\n"
    "  verify STORE [--progress bar|json|none] [--json]\n"
    "                                checksums and structure of a store\n"
    "  simplify MESH -o OUT.vtk (--ratio R | --tets N | --max-error E) [--attribute A[,B..]]\n"
    "                                [--independent] [--attribute-weight W] [--boundary-weight W] [--feature-weight W]\n"
    "                                [--vertex-weight W] [--min-quality Q] [--threads N] [--json]\n"
    "                                [--method qem|sample [--field-error E] [--space-error E] [--border-error E]]\n"
    "                                simplification of a whole mesh: quadric edge collapses (qem) or the global sampler of §4.2\n"
    "  error ORIGINAL SIMPLIFIED [--samples N] [--json]\n"
    "                                mean/max field error and domain error (§4.2.5)\n"
    "  serve --data DIR [--port 8080] [--bind ADDR] [--token T] [--threads N] [--workers N] [--cache-mb M]\n"
    "                                [--max-sessions N] [--max-message-bytes B] [--max-messages-per-second N] [--max-image-side S]\n"
    "                                [--max-upload-mb M] [--max-jobs N] [--max-fps F] [--budget TETS] [--interaction-budget TETS]\n"
    "                                [--interaction-scale S] [--frame-ms MS] [--refine-growth G] [--web DIR]\n"
    "                                [--max-queued-jobs N (16)] [--job-memory-mb M (physical memory)] [--job-cpu-seconds S (none)] [--max-connections N (256)] [--max-connections-per-ip N (32)]\n"
    "                                [--hello-timeout S (10)] [--min-upload-rate BYTES_PER_S (4096, over 10 s windows)]\n"
    "                                [--worker-idle-release S (5; 0: never)]  a render worker idle that long gives back its scene and buffers\n"
    "                                [--read-only]  a replica beside a writer: no uploads, jobs or deletes (docs/deploy.md)\n"
    "                                [--memory-mb M]  fit the still budget and cache to M MB (the process's cgroup limit is read too)\n"
    "                                the viewer: web client at /, REST API under /api/v1/, WebSocket sessions\n"
    "  loadtest --url ws://HOST:PORT/api/v1/session --dataset NAME [--clients N] [--duration S] [--path orbit|random|orbit-pause]\n"
    "                                [--orbit S] [--pause S] [--save-refinement DIR]\n"
    "                                [--rate HZ] [--size WxH] [--token T] [--allow-remote] [--no-reconnect] [--json]\n"
    "                                concurrent sessions replaying a camera path: fps, latency, bytes, errors\n"
    "  streamlines MESH|STORE --field V --seeds SPEC -o OUT.vtk [--direction forward|backward|both] [--max-steps S]\n"
    "                                [--max-length L] [--tolerance T] [--max-points P] [--json]   stream lines as VTK polylines (docs/streamlines.md)\n"
    "  diffusion-surfaces MESH|STORE --tensor T --seeds SPEC -o OUT.vtk [--min-cp C] [--min-cl C] [--edge L] [--max-bend DEG]\n"
    "                                [--max-triangles N] [--json]   surfaces of a tensor field's planar regions as VTK polygons (docs/streamlines.md)"
    "\n"
    "MESH: .vtk (legacy ASCII/BINARY), .vtu, .msh (Gmsh 2.2/4.1), .node/.ele (TetGen), .off, .exo/.e/.g (Exodus II), .cgns/.adf (CGNS), an OpenFOAM case folder or its .foam file\n";

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2 || !std::strcmp(argv[1], "--help") || !std::strcmp(argv[1], "-h") || !std::strcmp(argv[1], "help")) {
    std::fputs(kUsage, argc < 2 ? stderr : stdout);
    return argc < 2 ? 2 : 0;
  }
  std::string command = argv[1];
  std::vector<std::string> args(argv + 2, argv + argc);
  try {
    if (command == "info") return tetrascope::apps::run_info(args);
    if (command == "segment") return tetrascope::apps::run_segment(args);
    if (command == "verify") return tetrascope::apps::run_verify(args);
    if (command == "preprocess") return tetrascope::apps::run_preprocess(args);
    if (command == "cut") return tetrascope::apps::run_cut(args);
    if (command == "render") return tetrascope::apps::run_render(args);
    if (command == "simplify") return tetrascope::apps::run_simplify(args);
    if (command == "error") return tetrascope::apps::run_error(args);
    if (command == "serve") return tetrascope::apps::run_serve(args);
    if (command == "loadtest") return tetrascope::apps::run_loadtest(args);
    if (command == "streamlines") return tetrascope::apps::run_streamlines(args);
    if (command == "diffusion-surfaces") return tetrascope::apps::run_diffusion_surfaces(args);
    std::fprintf(stderr, "tetrascope: unknown command '%s'\n\n%s", command.c_str(), kUsage);
    return 2;
  } catch (const std::invalid_argument& e) {
    std::fprintf(stderr, "tetrascope %s: %s\n", command.c_str(), e.what());
    return 2;
  } catch (const tetrascope::renderer::RenderError& e) {
    std::fprintf(stderr, "tetrascope %s: rendering: %s\n", command.c_str(), e.what());
    return 1;
  } catch (const tetrascope::storage::MeshError& e) {
    std::fprintf(stderr, "tetrascope %s: %s\n", command.c_str(), e.what());
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "tetrascope %s: error: %s\n", command.c_str(), e.what());
    return 1;
  }
}
