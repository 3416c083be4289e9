/* The subcommands; each takes the arguments after its name and returns the
 * program's exit status. */
#ifndef PBC_COMMANDS_H
#define PBC_COMMANDS_H

int pbc_cmd_blur(int argc, char **argv);
int pbc_cmd_phantom(int argc, char **argv);
int pbc_cmd_compare(int argc, char **argv);
int pbc_cmd_render(int argc, char **argv);
int pbc_cmd_devices(int argc, char **argv);
int pbc_cmd_demo(int argc, char **argv);

/* Shared checks of file arguments. */
/* Refuses an output path whose extension no writer knows (before any work). */
int pbc_check_output(const char *option, const char *path, int picture);
/* Refuses an output that names the same file as an input. */
int pbc_check_distinct(const char *out, const char *in);

#endif
