// doctest main of the audit suite.
#include "test_main.h"
