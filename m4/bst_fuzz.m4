# bst_fuzz.m4 - whether the fuzz targets of tests/fuzz can be built (`make fuzz`).

# BST_CHECK_FUZZ: FUZZ_CC (default clang) must compile and link a libFuzzer target with
# -fsanitize=fuzzer,address,undefined.  Sets the conditional BST_FUZZ; never fails.
AC_DEFUN([BST_CHECK_FUZZ], [
  AC_ARG_VAR([FUZZ_CC], [C compiler with libFuzzer for `make fuzz' (default: clang)])
  AS_IF([test "x$FUZZ_CC" = x], [FUZZ_CC=clang])
  AC_CACHE_CHECK([whether $FUZZ_CC builds libFuzzer targets], [bst_cv_fuzz], [
    cat > conftest_fuzz.c <<_BST_EOF
#include <stddef.h>
#include <stdint.h>
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) { return size && data[[0]] == 1; }
_BST_EOF
    AS_IF([$FUZZ_CC -fsanitize=fuzzer,address,undefined conftest_fuzz.c -o conftest_fuzz$EXEEXT \
             >&AS_MESSAGE_LOG_FD 2>&1 && test -x conftest_fuzz$EXEEXT],
          [bst_cv_fuzz=yes], [bst_cv_fuzz=no])
    rm -f conftest_fuzz.c conftest_fuzz$EXEEXT])
  AM_CONDITIONAL([BST_FUZZ], [test "x$bst_cv_fuzz" = xyes])
])
