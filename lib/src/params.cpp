// params: being written
#include "qjulia/params.h"
