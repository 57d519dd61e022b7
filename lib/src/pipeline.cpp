// pipeline: being written
#include "qjulia/pipeline.h"
