/* The MCU images' entry point: the firmware's forever loop. */
#include "fw.h"

int main(void)
{
    fw_run();
}
