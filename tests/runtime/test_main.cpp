// doctest main of the runtime suite.
#include "test_main.h"
