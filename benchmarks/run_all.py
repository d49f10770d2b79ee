"""Run every benchmark (``make bench``)."""
from benchmarks import bench_control, bench_links, bench_plant

if __name__ == "__main__":
    bench_plant.main()
    bench_control.main()
    bench_links.main()
