/* host_firmware: the firmware's pure core (src/) behind a pseudo-terminal instead of a UART.
 *
 *   host_firmware [--joints N]
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
        } else if (strcmp(argv[i], "--help") == 0 || strcmp(argv[i], "-h") == 0) {
            printf("usage: host_firmware [--joints N]   (N = 1..%u, default %u)\n",
                   (unsigned)FW_MAX_JOINTS, (unsigned)FW_DEFAULT_JOINTS);
            exit(0);
        } else {
            fprintf(stderr, "host_firmware: unknown argument %s (usage: host_firmware [--joints N])\n",
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

    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_signal; /* no SA_RESTART: poll() returns EINTR and the loop ends */
    sigemptyset(&sa.sa_mask);
    sigaction(SIGTERM, &sa, NULL);
    sigaction(SIGINT, &sa, NULL);
    signal(SIGPIPE, SIG_IGN);

    master = open_pty(slave_path, sizeof slave_path, &slave_fd);
    fw_init(&fw, (uint8_t)joints);
    printf("PORT %s\n", slave_path);
    fflush(stdout);

    next_tick = now_ns() + TICK_NS;
    while (!stop_requested) {
        struct pollfd pfd;
        int64_t wait_ns = next_tick - now_ns();
        int timeout_ms = wait_ns <= 0 ? 0 : (int)((wait_ns + 999999) / 1000000);
        int ready;

        pfd.fd = master;
        pfd.events = POLLIN;
        pfd.revents = 0;
        ready = poll(&pfd, 1, timeout_ms);
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
                report_pulses(&fw, shown);
                next_tick += TICK_NS;
                if (++caught_up >= MAX_CATCH_UP_TICKS) {
                    next_tick = now + TICK_NS;
                }
            }
        }
    }
    close(master);
    close(slave_fd);
    return 0;
}
