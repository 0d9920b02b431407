// GLSL 4.50 sources of the GL renderer's programs, and linking them.
#pragma once

#define GL_GLEXT_PROTOTYPES 1
#include <GL/glcorearb.h>

namespace tetrascope::renderer {

// Volume: one tet's front faces; each fragment intersects its view ray with the tet's planes
// (exact segment), then looks up the pre-integrated table over (front, back, length). With
// `near_pass`, the tet's back faces, and the segment starts at max(near plane, entry).
extern const char* const kTetVertex;
extern const char* const kTetFragment;
// Volume by projected tetrahedra: a tet's fan of triangles around its thick vertex
// (projected_tets.h); one table lookup a fragment on the interpolated segment.
extern const char* const kProjectedVertex;
extern const char* const kProjectedFragment;
// Lit triangles (boundary surface, isosurfaces) coloured by value or a solid colour; also
// write the distance along the ray to the second target (the volume stops there).
extern const char* const kSurfaceVertex;
extern const char* const kSurfaceFragment;
// Solid lines (silhouettes, wireframe, box) over kSurfaceVertex.
extern const char* const kLineFragment;

// Compiles and links a vertex and a fragment shader; throws RenderError with the driver's log.
GLuint link_program(const char* vertex_source, const char* fragment_source);

}  // namespace tetrascope::renderer
