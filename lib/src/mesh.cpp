// mesh: being written
#include "qjulia/mesh.h"
