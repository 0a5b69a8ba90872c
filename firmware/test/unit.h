/* A very small unit-test runner: a failed check prints file:line and both values, and
 * returns from the test. The runner's last line is "N passed, N failed". */
#ifndef DESKARM_UNIT_H
#define DESKARM_UNIT_H

#include <stdio.h>

extern int unit_failed; /* set by a failed check in the current test */

#define CHECK(cond)                                                                   \
    do {                                                                              \
        if (!(cond)) {                                                                \
            printf("    %s:%d: CHECK(%s) failed\n", __FILE__, __LINE__, #cond);       \
            unit_failed = 1;                                                          \
            return;                                                                   \
        }                                                                             \
    } while (0)

/* unsigned values, printed both ways on failure */
#define CHECK_EQ(actual, expected)                                                    \
    do {                                                                              \
        unsigned long a_ = (unsigned long)(actual);                                   \
        unsigned long e_ = (unsigned long)(expected);                                 \
        if (a_ != e_) {                                                               \
            printf("    %s:%d: %s == %lu (0x%lX), expected %s == %lu (0x%lX)\n",     \
                   __FILE__, __LINE__, #actual, a_, a_, #expected, e_, e_);           \
            unit_failed = 1;                                                          \
            return;                                                                   \
        }                                                                             \
    } while (0)

/* with a context string (e.g. the vector's name) */
#define CHECK_EQ_CTX(ctx, actual, expected)                                           \
    do {                                                                              \
        unsigned long a_ = (unsigned long)(actual);                                   \
        unsigned long e_ = (unsigned long)(expected);                                 \
        if (a_ != e_) {                                                               \
            printf("    %s:%d: [%s] %s == %lu (0x%lX), expected %lu (0x%lX)\n",      \
                   __FILE__, __LINE__, (ctx), #actual, a_, a_, e_, e_);              \
            unit_failed = 1;                                                          \
            return;                                                                   \
        }                                                                             \
    } while (0)

/* after calling a helper that may have failed */
#define CHECK_HELPER()                                                                \
    do {                                                                              \
        if (unit_failed) {                                                            \
            printf("    (from %s:%d)\n", __FILE__, __LINE__);                         \
            return;                                                                   \
        }                                                                             \
    } while (0)

typedef struct {
    const char *name;
    void (*fn)(void);
} unit_test_t;

#endif
