// Placeholder until the formula compiler lands.
#include "qjulia/formula.h"
