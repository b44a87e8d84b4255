/* numtext.h - numbers as text, both ways: the writer's shortest round-trip floats and the readers'
 * fast decimal parsing (numtext.c). */
#ifndef BST_NUMTEXT_H
#define BST_NUMTEXT_H

#include <stddef.h>
#include <stdint.h>

/* The shortest text of v that reads back (strtof) as the float nearest
 * v, in %g style: at most 15 characters plus the terminator.  digits > 0 prints that many
 * significant digits instead.  Returns the length; *back receives the value a reader stores.
 * buf: 16 bytes at least, all of which the fixed digits' fast path may store (past the
 * terminator too). */
int bsti_format_float(double v, int digits, char *buf, float *back);
/* The same for doubles (strtod, at most 24 characters plus the terminator; 32 bytes of room). */
int bsti_format_double(double v, int digits, char *buf, double *back);
/* The reference the float's text must equal (numtext.c): the fewest "%.*g" digits strtof reads
 * back as f. */
int bsti_format_float_search(float f, char *buf);
/* A normal float's text by the fixed-point replay of the search that doubles take (numtext.c),
 * not the shortest-digits way floats take where they can: the length, or 0 where it cannot decide
 * (then the search does).  For comparing the two ways. */
int bsti_format_float_general(float f, char *buf);
/* The reference the double's text must equal: the fewest "%.*g" digits strtod reads back as v
 * (a binary search over printf and strtod; v finite and non-zero). */
int bsti_format_double_search(double v, char *buf);

/* For tests: the 8 decimal digits of n < 10^8 (most significant first, values 0..9) as the fixed
 * digits' fast path makes them, and 1; 0 where that path is not built (d untouched). */
int bsti_numtext_digits8(uint32_t n, unsigned char d[8]);

/* The double strtod reads from the len characters at s (no terminator needed): *v and 1 when the
 * whole text is a decimal number, 0 when it is not (nothing else written to *v).  Plain decimals
 * of up to 19 significant digits and a power of ten within 1e22 are converted by one correctly
 * rounded operation (Clinger's fast path: the same double as strtod's); anything else goes to
 * strtod itself. */
int bsti_parse_double(const char *s, size_t len, double *v);
/* A number followed by one of the unit suffixes (NULL-terminated list; "" = no suffix), scaled by
 * the suffix's factor into *out (the specs' lengths: "16mm", "0.016m"): 0, or -1 when v is not
 * one. */
int bsti_parse_scaled(const char *v, const char *const *suffix, const double *factor, double *out);

#endif
