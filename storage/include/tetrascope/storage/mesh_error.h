// Errors raised while reading untrusted mesh files.
#pragma once

#include <stdexcept>
#include <string>

namespace tetrascope::storage {

// A problem with an input file, already phrased for the user:
// "mesh.vtk: line 17: expected 4 vertex ids for cell 9, got 3".
class MeshError : public std::runtime_error {
 public:
  explicit MeshError(const std::string& message) : std::runtime_error(message) {}
};

}  // namespace tetrascope::storage
