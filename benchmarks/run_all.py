"""Run every benchmark (``make bench``)."""
from benchmarks import (
    bench_campaign,
    bench_control,
    bench_ekf_step,
    bench_links,
    bench_mission_time,
    bench_mpc,
    bench_plant,
    bench_plant6,
    bench_sim,
    bench_speed,
    bench_timing,
    bench_view,
)

if __name__ == "__main__":
    bench_plant.main()
    bench_plant6.main()
    bench_control.main()
    bench_links.main()
    bench_timing.main()
    bench_ekf_step.main([])
    bench_campaign.main()
    bench_speed.main([])
    bench_sim.main(["--repeat", "1"])
    bench_mission_time.main(["--repeat", "1"])
    bench_mpc.main([])
    bench_view.main([])
