/* layers.h - the command line's layer arguments: FILE.xml, glass:SPEC, and a trailing ^ for a
 * reversed layer; loading them over one target basis; writing a result file. */
#ifndef BST_CLI_LAYERS_H
#define BST_CLI_LAYERS_H

#include "bsdfstack.h"

/* A layer spec ending in ^ is the layer reversed (back side to the exterior: bst_layer_flip).
 * The length of spec without that ^, and in *reversed (when not NULL) 1 when it has one, else 0:
 * every command that takes layer specs reads the ^ here. */
size_t cli_spec_reversed(const char *spec, int *reversed);

/* How layers are loaded: the basis, and the memory they and what follows may take. */
struct cli_basis_choice {
    int k;             /* Shirley-Chiu order, 0 = not given */
    const char *klems; /* "full", "half", "quarter" or NULL */
    double max_memory; /* --max-memory (bytes); 0 = the memory available now */
    int combining;     /* 1: the layers are combined next, in `work` precision */
    bst_precision work;
    const char *lower; /* the options that lower the need, for the message; NULL: a lower -k,
                          --precision single (where it lowers the need) or fewer --channels */
    int at_centre;     /* --glass-rule centre: panes at patch centres (WINDOW's), 0: averages */
    bst_rank3_rule rank3; /* --rank3: how rank-3 trees meet a finer grid (bst_bsdf_set_rank3_rule) */
    char *const *where;   /* where[i]: the place spec i was given ("FILE:LINE" of a batch line),
                             put before the messages about it; NULL: none */
};

/* The choice that loads layers over basis b itself (a Shirley-Chiu order or a named Klems basis). */
void cli_basis_choice_of(const bst_basis *b, struct cli_basis_choice *choice);

/* The memory guard: the peak a command will need (the layers read from files over `basis`, the
 * conversion's grid, the combination's work when choice->combining), estimated as in
 * bench/README.md, against choice->max_memory or the memory available (MemAvailable, or a
 * cgroup's limit when lower).  CLI_OK when it fits; else one error line naming the need, the
 * limit and the options that lower the need, and CLI_FAIL. */
int cli_memory_check(const char *sub, const bst_basis *basis, size_t n, bst_bsdf *const *files,
                     unsigned comps, bst_precision prec, const struct cli_basis_choice *choice);
/* The same over layers some of which are made from specs (bst_plan_memory_held; factored layers
 * count the writer's one grid, and the message says so). */
int cli_memory_check_held(const char *sub, const bst_basis *basis, size_t n,
                          const bst_plan_held *held, unsigned comps, bst_precision prec,
                          const struct cli_basis_choice *choice);
/* Parse SIZE: bytes, or a number with K, M, G or T (powers of 1024); CLI_OK or a usage error. */
int cli_parse_memory(const char *sub, const char *value, double *bytes);

struct cli_layers {
    size_t n;
    bst_layer **layers;
    bst_basis *basis;
    char *description; /* "layers (exterior first): ..." for the output's metadata */
    bst_glass **panes; /* panes[i]: layer i's spectral pane (glass: with spectral data, not
                          reversed), else NULL; all non-NULL: the stack can be combined per
                          wavelength (bst_stack_combine_spectral) */
    size_t npanes;     /* how many are non-NULL */
    char **notes;      /* notes[i]: layer i's pane in one line (cli_glass_summary), recorded in
                          the output's header; NULL for a file (and notes NULL: none kept) */
    int plan_warn;     /* cli_spectral_plan's reason is one to warn of (bst_plan_spectral) */
    int spectral;      /* cli_combine_run combined it per wavelength */
    char basis_why[160]; /* the plan's reason for the basis (bst_plan_basis.why) */
};

/* Parse -k VALUE (opt 'k') or --klems[=WHICH] (opt 'K') into choice; CLI_OK or a usage error. */
int cli_parse_basis_option(const char *sub, int opt, const char *value, struct cli_basis_choice *choice);

/* The options `combine` and `batch` share, parsed in one place: -k (short option 'k') and the
 * long options below, listed in a getopt_long table by CLI_STACK_LONGOPTS; a command's own long
 * options start at CLI_O_OWN. */
enum { CLI_O_KLEMS = 256, CLI_O_ONLY, CLI_O_CHANNELS, CLI_O_PRECISION, CLI_O_DROP, CLI_O_REDUCE,
       CLI_O_NOREDUCE, CLI_O_DENSE, CLI_O_STRICT, CLI_O_PERCH, CLI_O_MAXMEM, CLI_O_SPTOL,
       CLI_O_GLASSRULE, CLI_O_REDUCETOL, CLI_O_RANK3, CLI_O_OWN };
#define CLI_STACK_LONGOPTS                                                                         \
    {"klems", optional_argument, NULL, CLI_O_KLEMS}, {"only", required_argument, NULL, CLI_O_ONLY},  \
    {"channels", required_argument, NULL, CLI_O_CHANNELS},                                          \
    {"precision", required_argument, NULL, CLI_O_PRECISION},                                        \
    {"drop-tol", required_argument, NULL, CLI_O_DROP},                                              \
    {"reduce", required_argument, NULL, CLI_O_REDUCE},                                              \
    {"reduce-tol", required_argument, NULL, CLI_O_REDUCETOL},                                       \
    {"no-reduce", no_argument, NULL, CLI_O_NOREDUCE}, {"dense", no_argument, NULL, CLI_O_DENSE},     \
    {"strict", no_argument, NULL, CLI_O_STRICT}, {"per-channel", no_argument, NULL, CLI_O_PERCH},   \
    {"max-memory", required_argument, NULL, CLI_O_MAXMEM},                                          \
    {"spectral-tol", required_argument, NULL, CLI_O_SPTOL},                                         \
    {"glass-rule", required_argument, NULL, CLI_O_GLASSRULE},                                       \
    {"rank3", required_argument, NULL, CLI_O_RANK3}

/* How a tree is reduced: --reduce PCT (pct -1 for --no-reduce) and --reduce-tol T (INFINITY:
 * the percentile alone); bst_bsdf_write_opts's reduce_pct and reduce_tol. */
struct cli_reduce {
    double pct, tol;
};
/* Parse --reduce-tol's value into *tol (a number >= 0, or "none"); CLI_OK or a usage error. */
int cli_parse_reduce_tol(const char *sub, const char *arg, double *tol);

struct cli_stack_args {
    struct cli_basis_choice basis;
    const char *channels; /* --channels, or NULL */
    struct cli_reduce reduce; /* default 90 and BST_REDUCE_TOL */
    int per_channel;      /* --per-channel */
    bst_stack_opts so;    /* --only, --precision, --drop-tol, --dense, --strict */
    bst_spectral_opts sp; /* --spectral-tol, --glass-rule (also in basis.at_centre) */
};
void cli_stack_args_init(struct cli_stack_args *a);
/* Option c with value arg: CLI_OK when it is one of the shared options and parsed, a usage error
 * (printed) when its value is wrong, -1 when c is not one of them. */
int cli_stack_option(const char *sub, int c, const char *arg, struct cli_stack_args *a);

/* Load every layer spec over the basis chosen by `choice` (or the default: the finest tensor-tree
 * order among the files, else the Klems basis of a Klems file, else Shirley-Chiu k = 5).
 * channels: comma-separated names or NULL; comps: the components to read from files (BST_COMP_BIT
 * mask, 0 = all); prec: the precision of dense components read from files.  Prints one error
 * line and returns CLI_FAIL. */
int cli_layers_load(struct cli_layers *set, bst_ctx *ctx, const char *sub, size_t n,
                    char **specs, const struct cli_basis_choice *choice, const char *channels,
                    unsigned comps, bst_precision prec);
void cli_layers_free(struct cli_layers *set);

/* How the batch's basis was chosen, so that another process (an MPI rank) makes the same one:
 * a Shirley-Chiu order, a named Klems basis, or the Klems basis of the file specs[file]. */
struct cli_basis_pick {
    int k;         /* 0 when not this */
    char klems[8]; /* "full", "half", "quarter", or "" */
    long file;     /* -1 when not this */
    char why[160]; /* the rule that chose (bst_plan_basis.why) */
};
/* Check every spec as cli_layers_load would load it (all components), without resampling the
 * files: read each file, choose the basis (told in *pick), run the memory guard over all, make
 * each pane once; structure[i] gets the structure layer i will have once loaded (a pane
 * diagonal; a file dense when a component fills more than BST_SPARSE_MAX_FILL of its domain, as
 * bst_bsdf_to_layer decides).  CLI_OK, or one error line printed.  The reader's warnings are
 * printed here. */
int cli_layers_check(bst_ctx *ctx, const char *sub, size_t n, char **specs,
                     const struct cli_basis_choice *choice, const char *channels,
                     bst_precision prec, struct cli_basis_pick *pick, bst_structure *structure);
/* The basis *pick names (specs: those it was picked from). */
int cli_basis_make(bst_ctx *ctx, const char *sub, const struct cli_basis_pick *pick, char **specs,
                   const char *channels, bst_precision prec, bst_basis **basis);
/* One spec's layer over basis, as cli_layers_load makes it (all components; the reader's
 * warnings are not printed again), its spectral pane or NULL, and (note not NULL) a pane's line
 * for the header or NULL.  Errors name `what`. */
int cli_layer_load(bst_ctx *ctx, const char *sub, const char *what, const char *spec,
                   const bst_basis *basis, const struct cli_basis_choice *choice,
                   const char *channels, bst_precision prec, bst_layer **layer, bst_glass **pane,
                   char **note);
/* Append to *description the header line of each pane among the n layers idx[0..n-1] of all
 * ("\nlayer J SPEC: NOTE", J counted from 1 in this stack); CLI_OK or an error line. */
int cli_note_panes(const char *sub, char **description, const struct cli_layers *all, size_t n,
                   const size_t *idx, char *const *specs);

/* The reader completes what a file leaves out (BST_WDATA): a transmission from the other side's by
 * reciprocity, as every TensorTree4 file expects (silently here), anything else as zero, which
 * changes the physics: "warning: PATH: not in the file, HOW as zero: CHANNEL COMP, ..." (combine:
 * "taken", convert: "written"), then the reader's other notes (cli_warn_bsdf); ctx cleared.  The
 * components outside comps (BST_COMP_BIT mask, 0 = all) are not named. */
void cli_warn_zero_components(const char *sub, const char *path, const bst_bsdf *b, unsigned comps,
                              const char *how, bst_ctx *ctx);

/* SOURCE_DATE_EPOCH (reproducible-builds.org) as the written header's date, so that two runs can
 * give byte-identical files: *date = buf holding it, or NULL (unset or empty: the current date).
 * A value that is not a whole number of seconds from 0 to the end of year 9999 is an error, as the
 * specification asks (it was ignored): one line naming it, CLI_FAIL.  The commands that write
 * XML call it before their work too, so that the error comes before the work. */
int cli_source_date(const char *sub, char *buf, size_t size, const char **date);
/* Write a layer as BSDF XML to path ("-" = stdout), atomically, reduced as reduce says. */
int cli_write_layer(bst_ctx *ctx, const char *sub, const bst_layer *l, const char *path,
                    const struct cli_reduce *reduce, int argc, char **argv, const struct cli_layers *set);
/* The same for a variable-resolution system (bst_bsdf_write_varres): coarse and fine columns v. */
int cli_write_varres(bst_ctx *ctx, const char *sub, const bst_layer *coarse, const bst_varres *v,
                     const char *path, const struct cli_reduce *reduce, int argc, char **argv,
                     const struct cli_layers *set);

/* Whether the stack is combined wavelength by wavelength (1) or by band values per channel (0),
 * and why, into why[0..size-1], as bst_plan_spectral decides (set->plan_warn: a reason to warn
 * of); -1 after an error line. */
int cli_spectral_plan(bst_ctx *ctx, const char *sub, struct cli_layers *set, int per_channel,
                      char *why, size_t size);
/* The stack per wavelength (as cli_spectral_plan allows; channels: layer 1's that every layer
 * has), with per-layer absorptance into abs[0], abs[1] when they are not NULL. */
int cli_combine_spectral(bst_ctx *ctx, const char *sub, const struct cli_layers *set,
                         const bst_spectral_opts *sp, const bst_stack_opts *so, double *abs[2],
                         bst_layer **sys);
/* Columns cols of the system per wavelength in one band channel (bst_stack_columns_spectral_layers,
 * the stack as cli_combine_spectral takes it). */
int cli_columns_spectral(bst_ctx *ctx, const char *sub, const struct cli_layers *set,
                         const bst_spectral_opts *sp, const char *channel, size_t ncols,
                         const size_t *cols, bst_columns_opts *o, bst_mat **tf, bst_mat **rf);
/* Append "spectral: WHY" to set->description (the output's metadata); -v also prints it, and so
 * does set->plan_warn, as a warning. */
int cli_note_spectral(const char *sub, struct cli_layers *set, const char *why, int verbose);

/* How cli_combine_run runs a stack. */
struct cli_run_opts {
    int verbose;         /* -v: print the plan's reason */
    int consume;         /* the layers may be freed at their last use (bst_stack_combine_consume;
                          * not with absorptance); set->layers[i] are NULL after */
    double *abs[2];      /* per-layer absorptance, front and back incidence (channel x layer x
                          * patch each), or NULL: not wanted */
    void (*spectral_step)(const bst_stack_step *, void *); /* per wavelength: the steps' callback
                          * (bst_stack_opts.on_step) instead of args->so's, or NULL */
    char *warning;       /* the combination's warning text, when there is one, or NULL */
    size_t warning_size;
};
/* The run step of combine and batch: plan (cli_spectral_plan, its reason noted in set's
 * description), then combine per wavelength or per channel, absorptance beside it when asked.
 * where: the stack's name in messages (a batch line) or NULL.  CLI_OK, or one error line printed
 * and *sys NULL. */
int cli_combine_run(bst_ctx *ctx, const char *sub, const char *where, struct cli_layers *set,
                    const struct cli_stack_args *args, const struct cli_run_opts *ro, bst_layer **sys);

/* Shades made from their geometry (shades.c): whether spec is one (venetian:, perforated:,
 * woven:, shade:FILE); the spec parsed (a trailing ^ dropped); its layer over basis (the ^ left
 * to the caller; a dense blind's components in precision prec, as files are read); its check,
 * telling the structure its layer will have.  Library statuses, the message in ctx. */
int cli_is_shade(const char *spec);
int cli_shade_parse(bst_ctx *ctx, const char *spec, bst_shade_model *m);
int cli_shade_layer(bst_ctx *ctx, const char *spec, const bst_basis *basis, size_t nch,
                    const char **chnames, bst_precision prec, bst_layer **l);
int cli_shade_check(bst_ctx *ctx, const char *spec, bst_structure *structure);
/* What its layer over basis in precision prec will hold (bst_shade_model_plan), for the memory
 * guard. */
int cli_shade_plan(bst_ctx *ctx, const char *spec, const bst_basis *basis, size_t nch,
                   const char *const *chnames, bst_precision prec, bst_plan_held *held);

#endif
