/* SPDX-License-Identifier: BSD-3-Clause */
/* cmake/probe/mpi/probe.c — the smallest MPI program: it must compile and link. */
#include <mpi.h>

int main(int argc, char **argv) {
    int rank = 0;
    MPI_Init(&argc, &argv);
    MPI_Comm_rank(MPI_COMM_WORLD, &rank);
    MPI_Finalize();
    return rank;
}
