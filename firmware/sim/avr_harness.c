/* avr_harness: the ATmega328P firmware image (the .hex avrdude would flash, or the .elf)
 * run in libsimavr, with its USART0 on a pseudo-terminal and its servo pins measured.
 *
 *   avr_harness [--mcu atmega328p] [--freq 16000000] [--speed X] FIRMWARE.hex|FIRMWARE.elf
 *
 * stdout, one line each, flushed at once:
 *   PORT /dev/pts/N                  first line: open it like a serial port (any baud rate;
 *                                    the emulated USART paces the bytes at its own 9600 baud)
 *   PULSE <pin> <t_us> <width_us> <period_us>
 *                                    a pulse ended on the pin (D9, D10, D11): when it rose
 *                                    (emulated microseconds since reset), how long it was high
 *                                    and the time since the pin's previous rising edge (0 for
 *                                    the first), to 1/16 us from the pins' change cycles
 *   OFF <pin> <t_us>                 a pin that was pulsing has had no rising edge for 25 ms
 *   CLOCK <emulated_s> <wall_s>      once per emulated second: how fast the emulation runs
 *   END <emulated_s> <wall_s>        on exit
 *   STACK <bytes>                    on exit: the deepest the stack went (SRAM is painted
 *                                    with 0xA5 before reset; the stack's lowest overwritten
 *                                    byte below RAMEND, 32 untouched bytes further down)
 * Every number comes from the emulated pins and cycle counter, nothing from the firmware.
 *
 * Time: the emulation is held to real time (--speed 1, the default: an emulated second takes
 * at least a wall second) so a host's timeouts and the firmware's 500 ms watchdog mean the
 * same thing on both sides; when the machine cannot keep up it runs slower and CLOCK says so.
 * --speed 0 runs as fast as it can.
 *
 * The pseudo-terminal is served from the emulation thread itself (libsimavr's uart_pty part
 * feeds the core from a second thread, and gives up when a client closes the port); this
 * process keeps its own slave fd open, so clients may close and reopen the port. Bytes from
 * the host go into the USART's receive FIFO while it holds fewer than 2 (the ATmega328P's
 * receive buffer is 2 bytes deep) and are delivered at the USART's byte time.
 *
 * SIGTERM or SIGINT: prints END and exits 0. A crashed core (e.g. a bad jump) exits 1. */
#define _GNU_SOURCE

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

#include "avr_ioport.h"
#include "avr_uart.h"
#include "sim_avr.h"
#include "sim_elf.h"
#include "sim_hex.h"
#include "sim_time.h"

DEFINE_FIFO(uint16_t, uart_fifo);

#define SERVICE_US 250u          /* pty and pin bookkeeping period, emulated */
#define OFF_AFTER_US 25000u      /* no rising edge for this long: the pin stopped pulsing */
#define UART_HW_DEPTH 2u         /* bytes the ATmega328P's receiver buffers */
#define LEAD_NS 1000000LL        /* run at most 1 ms ahead of the wall clock (--speed 1) */
#define PAINT 0xA5u              /* SRAM fill before the firmware starts */
#define PAINT_RUN 32u            /* untouched bytes that mark the end of the stack */
#define SRAM_START 0x100u        /* ATmega328P: registers and I/O below */

typedef struct {
    const char *name; /* Arduino pin name */
    char port;
    uint8_t bit;
    int level;
    int pulsing;                 /* rose within the last OFF_AFTER_US */
    avr_cycle_count_t rise;      /* cycle of the last rising edge */
    avr_cycle_count_t prev_rise; /* cycle of the one before (0: none yet) */
} pin_t;

static pin_t pins[] = {
    {"D9", 'B', 1, 0, 0, 0, 0},
    {"D10", 'B', 2, 0, 0, 0, 0},
    {"D11", 'B', 3, 0, 0, 0, 0},
};
#define N_PINS (sizeof pins / sizeof pins[0])

static avr_t *avr;
static avr_uart_t *uart;
static avr_irq_t *uart_input;
static int master_fd = -1;
static int slave_fd = -1;
static uint8_t in_buf[4096]; /* host -> AVR bytes not yet in the USART */
static size_t in_len;
static size_t in_done;
static uint8_t out_buf[4096]; /* AVR -> host bytes not yet written to the pty */
static size_t out_len;
static int64_t wall_start_ns;
static double speed = 1.0;
static uint64_t next_clock_s = 1;
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

static double cycles_to_us(avr_cycle_count_t c)
{
    return (double)c * 1e6 / (double)avr->frequency;
}

static int64_t emulated_ns(void)
{
    uint64_t f = avr->frequency;
    return (int64_t)((avr->cycle / f) * 1000000000ULL + (avr->cycle % f) * 1000000000ULL / f);
}

static void die(const char *what)
{
    fprintf(stderr, "avr_harness: %s: %s\n", what, strerror(errno));
    exit(1);
}

/* ---- pins ---- */

static void pin_changed(struct avr_irq_t *irq, uint32_t value, void *param)
{
    pin_t *p = (pin_t *)param;
    int level = value != 0u;
    (void)irq;
    if (level == p->level) {
        return;
    }
    p->level = level;
    if (level) {
        p->prev_rise = p->rise;
        p->rise = avr->cycle;
        p->pulsing = 1;
    } else if (p->rise != 0u) {
        avr_cycle_count_t period = p->prev_rise != 0u ? p->rise - p->prev_rise : 0u;
        printf("PULSE %s %.0f %.4f %.4f\n", p->name, cycles_to_us(p->rise),
               cycles_to_us(avr->cycle - p->rise), cycles_to_us(period));
    }
}

static void check_pins_off(void)
{
    size_t i;
    for (i = 0; i < N_PINS; i++) {
        pin_t *p = &pins[i];
        if (p->pulsing && !p->level && cycles_to_us(avr->cycle - p->rise) > OFF_AFTER_US) {
            p->pulsing = 0;
            p->prev_rise = 0; /* the next pulse starts a new train: no period across the gap */
            printf("OFF %s %.0f\n", p->name, cycles_to_us(avr->cycle));
        }
    }
}

/* ---- UART <-> pseudo-terminal ---- */

static void uart_output(struct avr_irq_t *irq, uint32_t value, void *param)
{
    (void)irq;
    (void)param;
    if (out_len < sizeof out_buf) {
        out_buf[out_len++] = (uint8_t)value;
    }
}

static void pty_exchange(void)
{
    if (in_done == in_len) {
        ssize_t r = read(master_fd, in_buf, sizeof in_buf);
        in_done = 0;
        in_len = r > 0 ? (size_t)r : 0u; /* EAGAIN: nothing; EIO: no client has it open */
    }
    while (in_done < in_len && uart_fifo_get_read_size(&uart->input) < UART_HW_DEPTH) {
        avr_raise_irq(uart_input, in_buf[in_done++]);
    }
    if (out_len > 0u) {
        ssize_t w = write(master_fd, out_buf, out_len);
        if (w > 0) {
            memmove(out_buf, out_buf + w, out_len - (size_t)w);
            out_len -= (size_t)w;
        }
    }
}

static avr_cycle_count_t service(struct avr_t *a, avr_cycle_count_t when, void *param)
{
    (void)a;
    (void)param;
    pty_exchange();
    check_pins_off();
    if (emulated_ns() >= (int64_t)next_clock_s * 1000000000LL) {
        printf("CLOCK %.3f %.3f\n", (double)emulated_ns() / 1e9,
               (double)(now_ns() - wall_start_ns) / 1e9);
        next_clock_s++;
    }
    return when + avr_usec_to_cycles(avr, SERVICE_US);
}

/* Hold the emulation to real time (times speed): wait while it is ahead, waking early when
 * the host writes. */
static void pace(void)
{
    int64_t ahead;
    if (speed <= 0.0) {
        return;
    }
    ahead = (int64_t)((double)emulated_ns() / speed) - (now_ns() - wall_start_ns);
    if (ahead > LEAD_NS) {
        /* watch the pty only when its bytes would be read (else it stays readable and the
         * wait would end at once) */
        struct pollfd pfd = {master_fd, (short)(in_done == in_len ? POLLIN : 0), 0};
        struct timespec ts = {ahead / 1000000000LL, ahead % 1000000000LL};
        (void)ppoll(&pfd, 1, &ts, NULL);
    }
}

static void no_sleep(struct avr_t *a, avr_cycle_count_t how_long)
{
    (void)a;
    (void)how_long; /* pace() does the waiting */
}

static void open_pty(void)
{
    struct termios tio;
    master_fd = posix_openpt(O_RDWR | O_NOCTTY);
    if (master_fd < 0 || grantpt(master_fd) != 0 || unlockpt(master_fd) != 0) {
        die("posix_openpt");
    }
    slave_fd = open(ptsname(master_fd), O_RDWR | O_NOCTTY);
    if (slave_fd < 0) {
        die("open pty slave");
    }
    if (tcgetattr(slave_fd, &tio) == 0) {
        cfmakeraw(&tio);
        (void)tcsetattr(slave_fd, TCSANOW, &tio);
    }
    if (fcntl(master_fd, F_SETFL, fcntl(master_fd, F_GETFL) | O_NONBLOCK) != 0) {
        die("fcntl");
    }
}

static avr_uart_t *find_uart0(void)
{
    avr_io_t *io;
    for (io = avr->io_port; io != NULL; io = io->next) {
        if (strcmp(io->kind, "uart") == 0 && io->irq_ioctl_get == AVR_IOCTL_UART_GETIRQ('0')) {
            return (avr_uart_t *)io;
        }
    }
    return NULL;
}

static void paint_sram(void)
{
    unsigned a;
    for (a = SRAM_START; a <= avr->ramend; a++) {
        avr->data[a] = PAINT;
    }
}

/* Bytes from RAMEND down to the lowest one the stack overwrote. */
static unsigned stack_used(void)
{
    unsigned a = avr->ramend;
    unsigned run = 0;
    unsigned low = avr->ramend + 1u;
    while (a >= SRAM_START && run < PAINT_RUN) {
        if (avr->data[a] == PAINT) {
            run++;
        } else {
            run = 0;
            low = a;
        }
        a--;
    }
    return avr->ramend + 1u - low;
}

static void report_end(void)
{
    printf("END %.3f %.3f\n", (double)emulated_ns() / 1e9, (double)(now_ns() - wall_start_ns) / 1e9);
    printf("STACK %u\n", stack_used());
}

static int ends_with(const char *s, const char *suffix)
{
    size_t n = strlen(s);
    size_t m = strlen(suffix);
    return n >= m && strcmp(s + n - m, suffix) == 0;
}

static void load(const char *path, const char *mcu, uint32_t freq, elf_firmware_t *f)
{
    memset(f, 0, sizeof *f);
    if (ends_with(path, ".hex")) {
        ihex_chunk_p chunks = NULL;
        int n = read_ihex_chunks(path, &chunks);
        int i;
        if (n <= 0) {
            fprintf(stderr, "avr_harness: %s: not a readable Intel HEX file\n", path);
            exit(2);
        }
        for (i = 0; i < n; i++) {
            if (chunks[i].baseaddr < 0x10000u) { /* flash; EEPROM/fuses live far above */
                f->flash = chunks[i].data;
                f->flashsize = chunks[i].size;
                f->flashbase = chunks[i].baseaddr;
            }
        }
        if (f->flash == NULL) {
            fprintf(stderr, "avr_harness: %s: no flash contents\n", path);
            exit(2);
        }
    } else if (elf_read_firmware(path, f) != 0) {
        fprintf(stderr, "avr_harness: %s: not a readable AVR ELF file\n", path);
        exit(2);
    }
    snprintf(f->mmcu, sizeof f->mmcu, "%s", mcu);
    f->frequency = freq;
}

int main(int argc, char **argv)
{
    const char *mcu = "atmega328p";
    uint32_t freq = 16000000u;
    const char *path = NULL;
    elf_firmware_t f;
    uint32_t flags = 0;
    size_t i;
    int iter = 0;
    int i_arg;
    struct sigaction sa;

    for (i_arg = 1; i_arg < argc; i_arg++) {
        if (strcmp(argv[i_arg], "--mcu") == 0 && i_arg + 1 < argc) {
            mcu = argv[++i_arg];
        } else if (strcmp(argv[i_arg], "--freq") == 0 && i_arg + 1 < argc) {
            freq = (uint32_t)strtoul(argv[++i_arg], NULL, 10);
        } else if (strcmp(argv[i_arg], "--speed") == 0 && i_arg + 1 < argc) {
            speed = strtod(argv[++i_arg], NULL);
        } else if (argv[i_arg][0] != '-' && path == NULL) {
            path = argv[i_arg];
        } else {
            fprintf(stderr, "usage: avr_harness [--mcu atmega328p] [--freq 16000000] [--speed X] "
                            "FIRMWARE.hex|FIRMWARE.elf\n");
            return 2;
        }
    }
    if (path == NULL || freq == 0u) {
        fprintf(stderr, "usage: avr_harness [--mcu atmega328p] [--freq 16000000] [--speed X] "
                        "FIRMWARE.hex|FIRMWARE.elf\n");
        return 2;
    }
    load(path, mcu, freq, &f);
    avr = avr_make_mcu_by_name(f.mmcu);
    if (avr == NULL) {
        fprintf(stderr, "avr_harness: libsimavr does not know the MCU %s\n", f.mmcu);
        return 2;
    }
    avr_init(avr);
    avr->log = 0; /* libsimavr's own chatter would mix into our stdout protocol */
    avr_load_firmware(avr, &f);
    avr->frequency = freq;
    avr->sleep = no_sleep;
    paint_sram();

    uart = find_uart0();
    if (uart == NULL) {
        fprintf(stderr, "avr_harness: %s has no USART0 in libsimavr\n", f.mmcu);
        return 2;
    }
    /* binary protocol: no console echo of bytes, no usleep when the core polls UCSR0A */
    (void)avr_ioctl(avr, AVR_IOCTL_UART_SET_FLAGS('0'), &flags);
    uart_input = avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_INPUT);
    avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUTPUT),
                            uart_output, NULL);
    for (i = 0; i < N_PINS; i++) {
        avr_irq_t *irq = avr_io_getirq(avr, AVR_IOCTL_IOPORT_GETIRQ(pins[i].port), pins[i].bit);
        avr_irq_register_notify(irq, pin_changed, &pins[i]);
    }

    open_pty();
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_signal;
    sigaction(SIGTERM, &sa, NULL);
    sigaction(SIGINT, &sa, NULL);
    setvbuf(stdout, NULL, _IOLBF, 0);
    printf("PORT %s\n", ptsname(master_fd));

    wall_start_ns = now_ns();
    avr_cycle_timer_register_usec(avr, SERVICE_US, service, NULL);
    while (!stop_requested) {
        int state = avr_run(avr);
        if (state == cpu_Done || state == cpu_Crashed) {
            fprintf(stderr, "avr_harness: the core stopped (%s) at pc 0x%04x after %.3f s\n",
                    state == cpu_Done ? "done: sleep with interrupts off" : "crashed",
                    (unsigned)avr->pc, (double)emulated_ns() / 1e9);
            report_end();
            return 1;
        }
        if (state == cpu_Sleeping || ++iter >= 4096) {
            iter = 0;
            pace();
        }
    }
    report_end();
    close(slave_fd);
    close(master_fd);
    avr_terminate(avr);
    return 0;
}
