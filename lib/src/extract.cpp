// extract: being written
#include "qjulia/extract.h"
