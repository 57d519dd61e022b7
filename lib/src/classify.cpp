// classify: being written
#include "qjulia/classify.h"
