// doctest main of the converter suite.
#include "test_main.h"
