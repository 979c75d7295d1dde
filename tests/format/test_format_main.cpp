// doctest main of the format suite.
#include "test_main.h"
