// sample: being written
#include "qjulia/sample.h"
