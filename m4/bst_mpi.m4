# bst_mpi.m4 - whether bsdfstack-mpi (batches over MPI ranks, src/cli/batch_mpi.c) is built.

# BST_CHECK_MPI: --with-mpi[=yes|no|auto] (default auto).  The compile and link flags come from
# pkg-config's ompi-c (Debian's libopenmpi-dev), else from `$MPICC --showme:compile` and
# `--showme:link` (OpenMPI's wrapper, MPICC default mpicc); either way a program calling
# MPI_Init must then link.  Sets MPI_CFLAGS, MPI_LIBS and the conditional BST_MPI.  auto: silently
# off when nothing is found; yes: stops configure naming the Debian packages.
AC_DEFUN([BST_CHECK_MPI], [
  AC_ARG_WITH([mpi],
    [AS_HELP_STRING([--with-mpi@<:@=yes|no|auto@:>@],
                    [build bsdfstack-mpi, batches over MPI ranks (default: auto, when OpenMPI is found)])],
    [], [with_mpi=auto])
  AC_ARG_VAR([MPICC], [MPI compiler wrapper asked for flags when pkg-config has no ompi-c (default: mpicc)])
  bst_mpi=no
  AS_IF([test "x$with_mpi" != xno], [
    PKG_CHECK_MODULES([MPI], [ompi-c], [bst_mpi=maybe], [
      AS_IF([test "x$MPICC" = x], [MPICC=mpicc])
      AS_IF([$MPICC --showme:compile >/dev/null 2>&1], [
        MPI_CFLAGS=`$MPICC --showme:compile`
        MPI_LIBS=`$MPICC --showme:link`
        bst_mpi=maybe])])
    AS_IF([test "x$bst_mpi" = xmaybe], [
      AC_CACHE_CHECK([whether a program calling MPI_Init links], [bst_cv_mpi_links], [
        bst_save_CFLAGS=$CFLAGS; bst_save_LIBS=$LIBS
        CFLAGS="$CFLAGS $MPI_CFLAGS"; LIBS="$MPI_LIBS $LIBS"
        AC_LINK_IFELSE([AC_LANG_PROGRAM([[#include <mpi.h>]],
                                        [[MPI_Comm c; return MPI_Init(0, 0) ||
                                          MPI_Comm_split_type(MPI_COMM_WORLD, MPI_COMM_TYPE_SHARED, 0,
                                                              MPI_INFO_NULL, &c);]])],
                       [bst_cv_mpi_links=yes], [bst_cv_mpi_links=no])
        CFLAGS=$bst_save_CFLAGS; LIBS=$bst_save_LIBS])
      AS_IF([test "x$bst_cv_mpi_links" = xyes], [bst_mpi=yes], [bst_mpi=no])])
    AS_IF([test "x$with_mpi" = xyes && test "x$bst_mpi" != xyes],
      [AC_MSG_ERROR([--with-mpi: no MPI 3 library found: apt-get install libopenmpi-dev openmpi-bin])])
  ])
  AC_MSG_CHECKING([whether to build bsdfstack-mpi])
  AC_MSG_RESULT([$bst_mpi])
  AS_IF([test "x$bst_mpi" != xyes], [MPI_CFLAGS=; MPI_LIBS=])
  AC_SUBST([MPI_CFLAGS])
  AC_SUBST([MPI_LIBS])
  AM_CONDITIONAL([BST_MPI], [test "x$bst_mpi" = xyes])
])
