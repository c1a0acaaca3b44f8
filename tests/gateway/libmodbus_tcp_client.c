/* SPDX-License-Identifier: Apache-2.0 */
/* libmodbus's TCP client, an independent Modbus TCP master, through drivebus-gateway.
 *
 *   libmodbus_tcp_client PORT
 *   libmodbus_tcp_client PORT flood   reads FD00 (polled) and FD06 (not) of unit 1 until killed:
 *                                     "ready" after the first of each
 *
 * Prints one line per case, for the test to compare with the simulator:
 *   fd06 V            FC03 of an unpolled register of the pump (unit 1)
 *   fa01 V            FC06 of FA01 = 1700, then FC03 of FA01: the value read back
 *   w450 A B C        FC03 of W450-W452 of the fan (unit 2)
 *   unit99 TEXT       FC03 to a unit no drive answers: libmodbus's words for the exception
 *   write_fd06 TEXT   FC06 to a read-only register: the same
 * Exit status 0, or 1 when libmodbus could not connect or a case that must succeed failed. */
#include <errno.h>
#include <modbus.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int fail(const char* what) {
    fprintf(stderr, "libmodbus_tcp_client: %s: %s\n", what, modbus_strerror(errno));
    return 1;
}

int main(int argc, char** argv) {
    if (argc != 2 && !(argc == 3 && strcmp(argv[2], "flood") == 0)) {
        fprintf(stderr, "usage: libmodbus_tcp_client PORT [flood]\n");
        return 2;
    }
    modbus_t* ctx = modbus_new_tcp("127.0.0.1", atoi(argv[1]));
    if (ctx == NULL || modbus_connect(ctx) != 0) {
        return fail("connect");
    }
    modbus_set_response_timeout(ctx, 5, 0);
    uint16_t v[3] = {0, 0, 0};
    int status = 0;

    modbus_set_slave(ctx, 1);
    if (argc == 3) {
        for (int said = 0;;) {
            if (modbus_read_registers(ctx, 0xFD00, 1, v) != 1 || modbus_read_registers(ctx, 0xFD06, 1, v) != 1) {
                return fail("flood");
            }
            if (!said) {
                printf("ready\n");
                fflush(stdout);
                said = 1;
            }
        }
    }
    if (modbus_read_registers(ctx, 0xFD06, 1, v) != 1) {
        status = fail("read FD06");
    } else {
        printf("fd06 %u\n", v[0]);
    }
    if (modbus_write_register(ctx, 0xFA01, 1700) != 1) {
        status = fail("write FA01");
    } else if (modbus_read_registers(ctx, 0xFA01, 1, v) != 1) {
        status = fail("read FA01");
    } else {
        printf("fa01 %u\n", v[0]);
    }
    modbus_set_slave(ctx, 2);
    if (modbus_read_registers(ctx, 450, 3, v) != 3) {
        status = fail("read W450");
    } else {
        printf("w450 %u %u %u\n", v[0], v[1], v[2]);
    }
    modbus_set_slave(ctx, 99);
    if (modbus_read_registers(ctx, 0xFD06, 1, v) == -1) {
        printf("unit99 %s\n", modbus_strerror(errno));
    } else {
        printf("unit99 answered\n");
    }
    modbus_set_slave(ctx, 1);
    if (modbus_write_register(ctx, 0xFD06, 1) == -1) {
        printf("write_fd06 %s\n", modbus_strerror(errno));
    } else {
        printf("write_fd06 ok\n");
    }
    fflush(stdout);
    modbus_close(ctx);
    modbus_free(ctx);
    return status;
}
