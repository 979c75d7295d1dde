// doctest main of the tools suite.
#include "test_main.h"
