#pragma once
// The library headers the binding uses, in one place.
#include "qjulia/base/atomic_file.h"
#include "qjulia/base/error.h"
#include "qjulia/base/memory.h"
#include "qjulia/base/mesh.h"
#include "qjulia/base/progress.h"
#include "qjulia/base/validate.h"
#include "qjulia/field/params.h"
#include "qjulia/io/mesh_io.h"
#include "qjulia/mesh/compare.h"
#include "qjulia/pipeline/pipeline.h"
#include "qjulia/render/image.h"
#include "qjulia/render/render.h"
