/* host_firmware: the firmware's pure core (src/) behind a pseudo-terminal instead of a UART.
 *
 *   host_firmware [--joints N] [--range MM]
 *
 * --range MM simulates an HC-SR04 range sensor with a target MM millimetres away (RANGE frames
 * at 10 Hz once the board is in v2 mode). Lines on stdin change it while running:
 *   RANGE <mm>       the target is now <mm> away (the echo is timed as the sound would take)
 *   RANGE none       nothing comes back (the sensor's ~38 ms no-echo pulse)
 *
 * stdout, one line each, flushed at once:
 *   PORT /dev/pts/N        first line: open this path like a serial port (any baud rate)
 *   PWM <us> <us> ...      whenever a pulse width changes, one number per joint (0 = off)
 * STATUS replies to v2 PINGs go back over the pseudo-terminal. A 50 Hz tick is simulated
 * with the monotonic clock (poll() timeouts). SIGTERM or SIGINT ends it with status 0.
 *
 * The port survives clients closing and reopening it: this process keeps its own slave fd
 * open, so the master never sees a hang-up (Linux returns EIO from a master read while no
 * slave is open); should it happen anyway, it waits for the next tick and retries. */
#define _XOPEN_SOURCE 600 /* posix_openpt, grantpt, unlockpt, ptsname */
#define _DEFAULT_SOURCE   /* cfmakeraw */

#include <errno.h>
#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <termios.h>
#include <time.h>
#include <unistd.h>

#include "../src/fw.h"

#define TICK_NS (1000000000LL / SERVO_TICK_HZ)
#define MAX_CATCH_UP_TICKS 10 /* after a stall (suspend, debugger) resync instead of bursting */
#define NO_ECHO_PULSE_US 38000u /* what an HC-SR04 reports when nothing comes back */

/* the simulated range sensor */
static int range_enabled;
static uint16_t range_echo_us = NO_ECHO_PULSE_US;

/* The echo an HC-SR04 would time for a target mm millimetres away (343 m/s, there and back). */
static uint16_t echo_for_mm(long mm)
{
    long us;
    if (mm <= 0) {
        return 0u;
    }
    us = (mm * 2000L + 171L) / 343L;
    return us > 65535L ? (uint16_t)65535u : (uint16_t)us;
}

static int parse_range(const char *text, uint16_t *echo_us)
{
    char *end = NULL;
    long mm;
    if (strcmp(text, "none") == 0) {
        *echo_us = NO_ECHO_PULSE_US;
        return 1;
    }
    mm = strtol(text, &end, 10);
    if (end == text || *end != '\0' || mm < 0 || mm > 10000) {
        return 0;
    }
    *echo_us = echo_for_mm(mm);
    return 1;
}

static volatile sig_atomic_t stop_requested;

static void on_signal(int sig)
{
    (void)sig;
    stop_requested = 1;
}

static int64_t now_ns(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (int64_t)ts.tv_sec * 1000000000LL + (int64_t)ts.tv_nsec;
}

static void die(const char *what)
{
    fprintf(stderr, "host_firmware: %s: %s\n", what, strerror(errno));
    exit(1);
}

static int parse_joints(int argc, char **argv)
{
    int joints = FW_DEFAULT_JOINTS;
    int i;
    for (i = 1; i < argc; i++) {
        if (strcmp(argv[i], "--joints") == 0 && i + 1 < argc) {
            char *end = NULL;
            long n = strtol(argv[++i], &end, 10);
            if (end == argv[i] || *end != '\0' || n < 1 || n > FW_MAX_JOINTS) {
                fprintf(stderr, "host_firmware: --joints %s: expected a number from 1 to %u\n",
                        argv[i], (unsigned)FW_MAX_JOINTS);
                exit(2);
            }
            joints = (int)n;
        } else if (strcmp(argv[i], "--range") == 0 && i + 1 < argc) {
            if (!parse_range(argv[++i], &range_echo_us)) {
                fprintf(stderr, "host_firmware: --range %s: expected a distance in mm (0..10000) or none\n",
                        argv[i]);
                exit(2);
            }
            range_enabled = 1;
        } else if (strcmp(argv[i], "--help") == 0 || strcmp(argv[i], "-h") == 0) {
            printf("usage: host_firmware [--joints N] [--range MM]   (N = 1..%u, default %u)\n",
                   (unsigned)FW_MAX_JOINTS, (unsigned)FW_DEFAULT_JOINTS);
            exit(0);
        } else {
            fprintf(stderr, "host_firmware: unknown argument %s (usage: host_firmware [--joints N] [--range MM])\n",
                    argv[i]);
            exit(2);
        }
    }
    return joints;
}

static int open_pty(char *slave_path, size_t path_size, int *slave_fd)
{
    struct termios tio;
    const char *name;
    int master = posix_openpt(O_RDWR | O_NOCTTY);
    if (master < 0) {
        die("posix_openpt");
    }
    if (grantpt(master) != 0) {
        die("grantpt");
    }
    if (unlockpt(master) != 0) {
        die("unlockpt");
    }
    name = ptsname(master);
    if (name == NULL) {
        die("ptsname");
    }
    snprintf(slave_path, path_size, "%s", name);
    /* held open for the process's life: see the header comment */
    *slave_fd = open(slave_path, O_RDWR | O_NOCTTY);
    if (*slave_fd < 0) {
        die(slave_path);
    }
    if (tcgetattr(*slave_fd, &tio) != 0) {
        die("tcgetattr");
    }
    cfmakeraw(&tio); /* no echo, no CR/LF translation: every byte value passes untouched */
    cfsetispeed(&tio, B9600);
    cfsetospeed(&tio, B9600);
    if (tcsetattr(*slave_fd, TCSANOW, &tio) != 0) {
        die("tcsetattr");
    }
    if (fcntl(master, F_SETFL, fcntl(master, F_GETFL) | O_NONBLOCK) != 0) {
        die("fcntl");
    }
    return master;
}

static void report_pulses(const fw_t *fw, uint16_t *shown)
{
    uint8_t j;
    if (memcmp(shown, fw->pulse_us, fw->n_joints * sizeof shown[0]) == 0) {
        return;
    }
    memcpy(shown, fw->pulse_us, fw->n_joints * sizeof shown[0]);
    fputs("PWM", stdout);
    for (j = 0; j < fw->n_joints; j++) {
        printf(" %u", (unsigned)shown[j]);
    }
    putchar('\n');
    if (fflush(stdout) != 0) {
        stop_requested = 1; /* whoever read our stdout has gone */
    }
}

static void send_replies(fw_t *fw, int master)
{
    uint8_t out[FW_TX_SIZE];
    uint8_t n = fw_take_tx(fw, out, sizeof out);
    ssize_t done = 0;
    while (done < (ssize_t)n) {
        ssize_t w = write(master, out + done, (size_t)(n - done));
        if (w < 0) {
            if (errno == EINTR) {
                continue;
            }
            return; /* EAGAIN (nobody reading) or EIO (no slave): drop, like a lost reply */
        }
        done += w;
    }
}

/* Read "RANGE <mm>|none" lines from stdin; returns 0 at end of input (stop polling it). */
static int read_commands(void)
{
    static char line[64];
    static size_t used;
    char buf[64];
    ssize_t n = read(STDIN_FILENO, buf, sizeof buf);
    ssize_t i;
    if (n <= 0) {
        return n < 0 && errno == EINTR;
    }
    for (i = 0; i < n; i++) {
        if (buf[i] != '\n') {
            if (used + 1u < sizeof line) {
                line[used++] = buf[i];
            }
            continue;
        }
        line[used] = '\0';
        used = 0;
        if (strncmp(line, "RANGE ", 6) != 0 || !parse_range(line + 6, &range_echo_us)) {
            fprintf(stderr, "host_firmware: stdin: %s: expected RANGE <mm> or RANGE none\n", line);
        }
    }
    return 1;
}

int main(int argc, char **argv)
{
    static fw_t fw;
    uint16_t shown[FW_MAX_JOINTS] = {0};
    char slave_path[128];
    struct sigaction sa;
    int slave_fd;
    int master;
    int64_t next_tick;
    int joints = parse_joints(argc, argv);
    int stdin_open = range_enabled;

    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_signal; /* no SA_RESTART: poll() returns EINTR and the loop ends */
    sigemptyset(&sa.sa_mask);
    sigaction(SIGTERM, &sa, NULL);
    sigaction(SIGINT, &sa, NULL);
    signal(SIGPIPE, SIG_IGN);

    master = open_pty(slave_path, sizeof slave_path, &slave_fd);
    fw_init(&fw, (uint8_t)joints);
    fw_range_enable(&fw, (uint8_t)range_enabled);
    printf("PORT %s\n", slave_path);
    fflush(stdout);

    next_tick = now_ns() + TICK_NS;
    while (!stop_requested) {
        struct pollfd pfds[2];
        struct pollfd pfd;
        int64_t wait_ns = next_tick - now_ns();
        int timeout_ms = wait_ns <= 0 ? 0 : (int)((wait_ns + 999999) / 1000000);
        int ready;

        pfds[0].fd = master;
        pfds[0].events = POLLIN;
        pfds[0].revents = 0;
        pfds[1].fd = STDIN_FILENO;
        pfds[1].events = POLLIN;
        pfds[1].revents = 0;
        ready = poll(pfds, stdin_open ? 2u : 1u, timeout_ms);
        pfd = pfds[0];
        if (ready > 0 && stdin_open && (pfds[1].revents & (POLLIN | POLLHUP))) {
            stdin_open = read_commands();
            if (!(pfd.revents & (POLLIN | POLLHUP | POLLERR))) {
                ready = 0; /* only a command: go on to the tick */
            }
        }
        if (ready < 0) {
            if (errno == EINTR) {
                continue;
            }
            die("poll");
        }
        if (ready > 0 && (pfd.revents & POLLIN)) {
            uint8_t buf[256];
            for (;;) {
                ssize_t n = read(master, buf, sizeof buf);
                ssize_t i;
                if (n > 0) {
                    for (i = 0; i < n; i++) {
                        fw_feed(&fw, buf[i]);
                    }
                    continue;
                }
                if (n < 0 && errno == EINTR) {
                    continue;
                }
                if (n < 0 && errno != EAGAIN && errno != EIO) {
                    die("read");
                }
                break;
            }
            send_replies(&fw, master);
            report_pulses(&fw, shown);
        } else if (ready > 0) {
            /* POLLHUP/POLLERR without data: no slave open. Sleep to the tick, then retry. */
            wait_ns = next_tick - now_ns();
            if (wait_ns > 0) {
                struct timespec ts = {(time_t)(wait_ns / 1000000000LL),
                                      (long)(wait_ns % 1000000000LL)};
                nanosleep(&ts, NULL);
            }
        }

        {
            int64_t now = now_ns();
            int caught_up = 0;
            while (now >= next_tick && !stop_requested) {
                fw_tick(&fw);
                if (fw_range_due(&fw)) {
                    /* as main_msp430.c: report the last measurement, trigger the next */
                    if (fw.range_measuring) {
                        fw_range_result(&fw, range_echo_us);
                    }
                    fw_range_started(&fw);
                }
                report_pulses(&fw, shown);
                next_tick += TICK_NS;
                if (++caught_up >= MAX_CATCH_UP_TICKS) {
                    next_tick = now + TICK_NS;
                }
            }
            send_replies(&fw, master); /* RANGE frames come from ticks, not from input */
        }
    }
    close(master);
    close(slave_fd);
    return 0;
}
