// SPDX-License-Identifier: Apache-2.0
/* An independent Modbus RTU slave for drivebusd's tests, built on libmodbus:
 *   libmodbus_slave DEVICE SLAVE_ID
 * Serves 100 holding registers, register i starting at 1000 + i, at 19200 8N1. On SIGTERM
 * it prints every register that differs from its start value ("reg 3 = 4242") and exits 0. */
#include <errno.h>
#include <modbus.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static volatile sig_atomic_t stop = 0;

static void on_term(int sig) {
    (void)sig;
    stop = 1;
}

int main(int argc, char** argv) {
    if (argc != 3) {
        fprintf(stderr, "usage: libmodbus_slave DEVICE SLAVE_ID\n");
        return 2;
    }
    modbus_t* ctx = modbus_new_rtu(argv[1], 19200, 'N', 8, 1);
    if (ctx == NULL || modbus_set_slave(ctx, atoi(argv[2])) != 0 || modbus_connect(ctx) != 0) {
        fprintf(stderr, "libmodbus_slave: %s: %s\n", argv[1], modbus_strerror(errno));
        return 1;
    }
    modbus_mapping_t* map = modbus_mapping_new(0, 0, 100, 0);
    for (int i = 0; i < 100; ++i) {
        map->tab_registers[i] = (uint16_t)(1000 + i);
    }
    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_term;
    sigaction(SIGTERM, &sa, NULL);
    sigaction(SIGINT, &sa, NULL);
    /* Wake up every 100 ms to notice SIGTERM. */
    modbus_set_indication_timeout(ctx, 0, 100000);
    printf("ready\n");
    fflush(stdout);
    uint8_t query[MODBUS_RTU_MAX_ADU_LENGTH];
    while (!stop) {
        int rc = modbus_receive(ctx, query);
        if (rc > 0) {
            modbus_reply(ctx, query, rc, map);
        }
    }
    for (int i = 0; i < 100; ++i) {
        if (map->tab_registers[i] != (uint16_t)(1000 + i)) {
            printf("reg %d = %u\n", i, (unsigned)map->tab_registers[i]);
        }
    }
    fflush(stdout);
    modbus_mapping_free(map);
    modbus_close(ctx);
    modbus_free(ctx);
    return 0;
}
