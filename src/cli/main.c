/* main.c - the bsdfstack program: global options and dispatch to the subcommands.  A subcommand is
 * a function int cmd_NAME(int argc, char **argv) in src/cli/cmd_NAME.c, listed in cli_commands. */
#include <config.h>

#include <stdio.h>
#include <string.h>

#include "cli.h"
#include "interrupt.h"

const struct cli_command cli_commands[] = {
    {"combine", cmd_combine, "combine layers (exterior first) into the system's BSDF XML"},
    {"convert", cmd_convert, "write a BSDF file as a tensor tree or Klems matrices, resampled if asked"},
    {"glass", cmd_glass, "print a pane's T, R and absorptance against angle"},
    {"info", cmd_info, "summarize a BSDF file (basis, layers, T and R, balance) or a pane"},
    {"batch", cmd_batch, "combine many stacks listed in a file, each layer loaded once"},
    {"compare", cmd_compare, "how far two BSDFs agree: accordance and hemispherical values"},
    {"plot", cmd_plot, "draw scattered light for one incidence, or T and R against angle (PNG, SVG, PDF)"},
    {"view", cmd_view, "write an interactive HTML page showing BSDF files (one file, no network)"},
    {"query", cmd_query, "evaluate a BSDF file at pairs of directions, as RADIANCE does"},
    {"version", cmd_version, "print the program and library versions"},
    {NULL, NULL, NULL}
};

static const char main_help[] =
    "Usage: bsdfstack COMMAND [OPTIONS] [ARGUMENTS]\n"
    "       bsdfstack --help | --version\n"
    "\n"
    "Computes the BSDF of a window system from the BSDFs of its layers (Klems matrix formalism,\n"
    "Klems or Shirley-Chiu tensor-tree bases).  Layers are listed exterior first.\n"
    "\n"
    "Commands:\n";

static void print_main_help(FILE *fp)
{
    fputs(main_help, fp);
    for (const struct cli_command *c = cli_commands; c->name; c++)
        fprintf(fp, "  %-10s %s\n", c->name, c->summary);
    fputs("\n'bsdfstack COMMAND --help' describes each command; man bsdfstack-COMMAND too.\n"
          "Exit status: 0 on success, 1 on failure, 2 on a usage error.\n", fp);
}

int cmd_version(int argc, char **argv)
{
    if (argc > 1 && (strcmp(argv[1], "--help") == 0 || strcmp(argv[1], "-h") == 0)) {
        puts("Usage: bsdfstack version\nPrints the program and library versions.");
        return CLI_OK;
    }
    if (argc > 1)
        return cli_usage("version", "unexpected argument '%s'", argv[1]);
    printf("bsdfstack %s (library %s)\n", PACKAGE_VERSION, bst_version());
    return CLI_OK;
}

/* Run the command argv[1] names; its exit status. */
static int dispatch(int argc, char **argv, const char **sub)
{
    if (argc < 2)
        return cli_usage(NULL, "missing command");
    if (strcmp(argv[1], "--help") == 0 || strcmp(argv[1], "-h") == 0 ||
        strcmp(argv[1], "help") == 0) {
        print_main_help(stdout);
        return CLI_OK;
    }
    if (strcmp(argv[1], "--version") == 0 || strcmp(argv[1], "-V") == 0) {
        *sub = "version";
        return cmd_version(1, argv + 1);
    }
    for (const struct cli_command *c = cli_commands; c->name; c++)
        if (strcmp(argv[1], c->name) == 0) {
            *sub = c->name;
            return c->run(argc - 1, argv + 1);
        }
    return cli_usage(NULL, "unknown command '%s'", argv[1]);
}

int main(int argc, char **argv)
{
    cli_blas_kernels(argv); /* (may run the program again: before anything else) */
    cli_hold_std_fds();
    cli_interrupt_setup(); /* a signal removes the temporaries of outputs being written */
    cli_blas_setup(); /* spinning from the library's start: reading comes first */
    const char *sub = NULL;
    int rc = dispatch(argc, argv, &sub);
    /* whatever a command printed must have reached standard output: a full disk or a closed
     * descriptor is a failure, not a silent success */
    int out = cli_stdout_check(sub);
    return rc != CLI_OK ? rc : out;
}
