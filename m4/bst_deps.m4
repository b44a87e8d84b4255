# bst_deps.m4 - dependency checks that name the Debian package to install when they fail.

# BST_REQUIRE_PKG(VAR, MODULE, DEBIAN-PACKAGE)
AC_DEFUN([BST_REQUIRE_PKG], [
  PKG_CHECK_MODULES([$1], [$2], [],
    [AC_MSG_ERROR([$2 not found (pkg-config): install it with 'apt-get install $3'])])
])

# BST_CHECK_HEADER_LIB(VAR, HEADER, LIB, FUNCTION, DEBIAN-PACKAGE): HEADER and FUNCTION must be
# usable with the flags found for VAR.
AC_DEFUN([BST_CHECK_HEADER_LIB], [
  bst_save_CPPFLAGS=$CPPFLAGS; bst_save_LIBS=$LIBS
  CPPFLAGS="$CPPFLAGS $$1_CFLAGS"; LIBS="$$1_LIBS $LIBS"
  AC_CHECK_HEADER([$2], [],
    [AC_MSG_ERROR([$2 not found: install it with 'apt-get install $5'])])
  AC_CHECK_FUNC([$4], [],
    [AC_MSG_ERROR([$4 (lib$3) not found: install it with 'apt-get install $5'])])
  CPPFLAGS=$bst_save_CPPFLAGS; LIBS=$bst_save_LIBS
])

# BST_FIND_SUITESPARSE: CHOLMOD, UMFPACK and CXSparse.  SuiteSparse 5 ships no pkg-config files; Debian puts
# the headers in /usr/include/suitesparse.  Sets SUITESPARSE_CFLAGS and SUITESPARSE_LIBS.
AC_DEFUN([BST_FIND_SUITESPARSE], [
  AC_ARG_VAR([SUITESPARSE_CFLAGS], [C compiler flags for SuiteSparse (CHOLMOD, UMFPACK, CXSparse)])
  AC_ARG_VAR([SUITESPARSE_LIBS], [linker flags for SuiteSparse (CHOLMOD, UMFPACK, CXSparse)])
  AS_IF([test "x$SUITESPARSE_CFLAGS" = x], [
    SUITESPARSE_CFLAGS=
    for bst_dir in /usr/include/suitesparse /usr/local/include/suitesparse; do
      AS_IF([test -f "$bst_dir/cholmod.h"], [SUITESPARSE_CFLAGS="-I$bst_dir"; break])
    done])
  AS_IF([test "x$SUITESPARSE_LIBS" = x], [SUITESPARSE_LIBS="-lumfpack -lcholmod -lcxsparse -lsuitesparseconfig"])
  bst_save_CPPFLAGS=$CPPFLAGS; bst_save_LIBS=$LIBS
  CPPFLAGS="$CPPFLAGS $SUITESPARSE_CFLAGS"; LIBS="$SUITESPARSE_LIBS $LIBS"
  AC_CHECK_HEADERS([cholmod.h umfpack.h], [],
    [AC_MSG_ERROR([SuiteSparse headers (cholmod.h, umfpack.h) not found: install them with 'apt-get install libsuitesparse-dev'])])
  AC_CHECK_FUNC([cholmod_start], [],
    [AC_MSG_ERROR([CHOLMOD library not found: install it with 'apt-get install libsuitesparse-dev'])])
  AC_CHECK_FUNC([umfpack_dl_numeric], [],
    [AC_MSG_ERROR([UMFPACK library not found: install it with 'apt-get install libsuitesparse-dev'])])
  AC_CHECK_HEADERS([cs.h], [],
    [AC_MSG_ERROR([CXSparse header (cs.h) not found: install it with 'apt-get install libsuitesparse-dev'])])
  AC_CHECK_FUNC([cs_dl_spsolve], [],
    [AC_MSG_ERROR([CXSparse library not found: install it with 'apt-get install libsuitesparse-dev'])])
  CPPFLAGS=$bst_save_CPPFLAGS; LIBS=$bst_save_LIBS
])
