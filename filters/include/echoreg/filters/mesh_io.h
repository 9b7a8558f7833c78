// Bone models on disk (.stl, .vtp, .ply, .obj) to and from echoreg::core::TriangleMesh.
#pragma once

#include "echoreg/core/mesh.hpp"

#include <vtkPolyData.h>
#include <vtkSmartPointer.h>

#include <string>

namespace echoreg::filters {

/// The triangles of `polyData` (polygons are triangulated, coincident points merged exactly, so an
/// STL's per-triangle vertices become a shared, checkable mesh).
core::TriangleMesh toTriangleMesh(vtkPolyData* polyData);

/// Points and triangles (with point normals computed from the triangles).
vtkSmartPointer<vtkPolyData> toPolyData(const core::TriangleMesh& mesh);

/// Reads a mesh by extension (.stl, .vtp, .ply, .obj; case-insensitive). Throws FileError naming
/// the file when it is missing, unreadable, of an unknown kind, or has no triangles.
core::TriangleMesh readMesh(const std::string& path);

/// Writes .vtp (XML, binary, zlib) or .stl (binary) atomically. `polyData` may carry arrays.
void writeMesh(const std::string& path, vtkPolyData* polyData);
void writeMesh(const std::string& path, const core::TriangleMesh& mesh);

}  // namespace echoreg::filters
