#include <stdio.h>
#include "petblur.h"
int main(void) { return 0; }
